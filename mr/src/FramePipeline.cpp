#include "BackgroundTask.h"

#include <lightskin/capture/DepthFilter.h>
#include <lightskin/core/CpuTime.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/eval/ColourSpace.h>
#include <lightskin/gi/Techniques.h>
#include <lightskin/gi/common/CpuValGenerator.h>
#include <lightskin/gi/common/ValGenerator.h>
#include <lightskin/gi/common/ValOccupancyCull.h>
#include <lightskin/gi/common/ValSetMerger.h>
#include <lightskin/gi/differential/DifferentialIrradiance.h>
#include <lightskin/gl/DebugOutput.h>
#include <lightskin/gl/Readback.h>
#include <lightskin/mr/FramePipeline.h>
#include <lightskin/mr/SceneContent.h>
#include <lightskin/roomlight/RoomLightEstimator.h>
#include <lightskin/roommodel/RoomMemory.h>
#include <lightskin/roommodel/RoomModelFile.h>
#include <lightskin/tracking/TagWorld.h>

#include <epoxy/gl.h>
#include <glm/common.hpp>
#include <glm/exponential.hpp>
#include <glm/trigonometric.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <filesystem>
#include <limits>
#include <mutex>
#include <numbers>
#include <optional>
#include <span>
#include <thread>
#include <time.h>
#include <utility>

namespace lightskin::mr {

namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

void addTime(std::vector<gl::StageTime>& times, std::size_t& used, const char* name, double ms) {
    if (times.size() <= used) times.resize(used + 1);
    times[used].name = name;
    times[used].milliseconds = ms;
    ++used;
}

/// The scene's /roomModel object, checked whatever the pose mode (a bad one is said up front); a room memory only
/// where it can work: with tag tracking (it fuses tag-tracked frames) and depth registered to colour.
std::optional<roommodel::RoomMemory> roomMemoryFromScene(const render::Scene& scene, PoseMode poseMode,
                                                         bool registeredDepth, const std::string& sourceUri) {
    if (scene.roomModelJson.empty()) return std::nullopt;
    const std::string source = (scene.file.empty() ? std::string("scene") : scene.file.string());
    const roommodel::RoomMemorySettings settings =
        roommodel::roomMemorySettingsFromJson(scene.roomModelJson, source, "/roomModel");
    if (poseMode != PoseMode::Tracking) return std::nullopt;
    if (!registeredDepth) {
        log::warning(sourceUri + ": depth is not registered to colour; no room memory (/roomModel)");
        return std::nullopt;
    }
    roommodel::RoomMemory memory = roommodel::RoomMemory::create(settings);
    const glm::ivec3 r = memory.model().resolution();
    log::info("room memory: " + std::to_string(r.x) + "x" + std::to_string(r.y) + "x" + std::to_string(r.z) +
              " voxels, " + std::to_string(memory.model().voxelBytes() / 1000000) + " MB");
    return memory;
}

/// The scene's /tracking object: the tag world (inline, or {"file": path}) plus tracker options
/// taken out before the rest goes to TagWorld: "detector" (AprilTag detector settings, e.g.
/// {"quadDecimate": 1} for the 15-40 px tags of a 320x240 image) and "useDepth" (boolean:
/// depth-aided refinement). Every key is checked whatever the pose mode; a tag world file that does not
/// exist is an error only when `tracked` (the pose comes from the tags): a run with other poses may use a
/// scene whose tag world is written later (the main job's synth writes orbit.json's), and gets no tracker.
std::optional<tracking::PoseTracker> trackerFromScene(const render::Scene& scene, bool tracked) {
    const std::string source = (scene.file.empty() ? std::string("scene") : scene.file.string());
    nlohmann::json tracking = nlohmann::json::parse(scene.trackingJson);
    if (tracking.empty()) {
        if (!tracked) return std::nullopt;
        throw Error(source, std::nullopt,
                    "/tracking: --pose tracking needs a \"tracking\" object in the scene (tag family, size, bundle); "
                    "without tags use --pose fixed (the world is the camera frame) or --pose ground-truth");
    }
    tracking::TrackerSettings settings;
    if (tracking.contains("detector")) {
        settings.detector =
            tracking::detectorSettingsFromJson(tracking["detector"].dump(), source, "/tracking/detector");
        tracking.erase("detector");
    }
    if (tracking.contains("useDepth")) {
        if (!tracking["useDepth"].is_boolean())
            throw Error(source, std::nullopt,
                        "/tracking/useDepth: expected true or false, got " + tracking["useDepth"].dump());
        settings.useDepth = tracking["useDepth"].get<bool>();
        tracking.erase("useDepth");
    }
    if (tracking.contains("file")) {
        if (tracking.size() != 1 || !tracking["file"].is_string())
            throw Error(source, std::nullopt,
                        "/tracking/file: expected a path string, beside only detector and useDepth");
        const std::filesystem::path world = scene.file.parent_path() / tracking["file"].get<std::string>();
        if (!std::filesystem::exists(world) && !tracked) return std::nullopt;
        if (!std::filesystem::is_regular_file(world)) // name the scene key, not only the missing file
            throw Error(source, std::nullopt, "/tracking/file: tag world '" + world.string() + "' does not exist");
        return tracking::PoseTracker::create(tracking::TagWorld::load(world), settings);
    }
    return tracking::PoseTracker::create(tracking::TagWorld::fromJson(tracking.dump(), source, "/tracking"), settings);
}

} // namespace

const char* toString(PoseMode mode) noexcept {
    switch (mode) {
    case PoseMode::GroundTruth:
        return "ground-truth";
    case PoseMode::Tracking:
        return "tracking";
    case PoseMode::Fixed:
        return "fixed";
    }
    return "?";
}

PoseMode parsePoseMode(const std::string& text) {
    if (text == "ground-truth") return PoseMode::GroundTruth;
    if (text == "tracking") return PoseMode::Tracking;
    if (text == "fixed") return PoseMode::Fixed;
    throw Error("--pose", std::nullopt, "expected ground-truth, tracking or fixed, got '" + text + "'");
}

namespace {
/// The sparse points the renderer prepared for each mesh (Renderer::setScene with sparse points).
gi::SparsePointProvider sparsePointsOf(const render::Renderer& renderer) {
    return [&renderer](const gi::MeshInstance& instance) {
        const gi::SparsePointSet* points = renderer.sparsePoints(instance.meshId);
        LIGHTSKIN_ASSERT(points != nullptr, "lightskin::mr: the renderer prepared no sparse points");
        return *points;
    };
}

/// The real surface of a frame for the techniques (ViewParameters::realDepth): `depth` in metres,
/// registered to colour; `texture` the same map on the GPU, if uploaded (0 = none).
gi::RealDepthView realDepthView(const cv::Mat& depth, const CameraIntrinsics& k, const Pose& world_T_camera,
                                std::uint32_t texture) {
    return gi::RealDepthView{
        .texture = texture,
        .data = depth.ptr<float>(),
        .width = depth.cols,
        .height = depth.rows,
        .intrinsics = glm::vec4(float(k.fx), float(k.fy), float(k.cx), float(k.cy)),
        .camera_T_world = world_T_camera.inverse().matrixFloat(),
    };
}

/// The brute force on the pipeline's settings (the error and reference views).
std::unique_ptr<gi::IndirectIllumination> bruteForceFor(render::GiSettings settings, const render::Renderer& renderer) {
    settings.technique = gi::Technique::BruteForce;
    return gi::createTechnique(gi::configFor(settings), sparsePointsOf(renderer));
}
} // namespace

// The scene lights as multi-scale PRT's entry-point lights (their transfer between the virtual objects).
std::vector<gi::PrtLight> prtLightsFromScene(const render::Scene& scene) {
    std::vector<gi::PrtLight> out;
    for (const render::SceneLight& light : scene.lights) {
        gi::PrtLight l;
        l.position = light.position;
        // The estimated light moves every frame; a technique created with the lights is not rebuilt for it.
        l.power = light.type == render::LightType::Estimated ? glm::vec3(0.0f) : light.power;
        l.direction = light.direction;
        if (light.type == render::LightType::Spot) {
            l.cosInner = std::cos(glm::radians(light.coneAngleDegrees));
            l.cosOuter = std::cos(glm::radians(light.coneAngleDegrees + light.coneFalloffDegrees));
        }
        out.push_back(l);
    }
    return out;
}

namespace {
gi::VirtualLight virtualLightOf(const render::SceneLight& l) {
    gi::VirtualLight v;
    v.type = l.type == render::LightType::Spot ? gi::VirtualLight::Type::Spot : gi::VirtualLight::Type::Point;
    v.position = l.position;
    v.direction = l.direction;
    v.spotHalfAngle = std::min(1.5f, glm::radians(l.coneAngleDegrees + 0.5f * l.coneFalloffDegrees));
    v.intensity = l.power / float(4.0 * std::numbers::pi);
    return v;
}
} // namespace

std::vector<gi::VirtualLight> virtualLightsFromScene(const render::Scene& scene) {
    std::vector<gi::VirtualLight> lights;
    lights.reserve(scene.lights.size());
    for (const render::SceneLight& l : scene.lights) lights.push_back(virtualLightOf(l));
    return lights;
}

namespace {
// The renderer's light model (Renderer::shade) for the direct light of imperfect volumes' mesh points.
std::vector<gi::VolumeLight> volumeLightsFromScene(const render::Scene& scene) {
    std::vector<gi::VolumeLight> lights;
    for (const render::SceneLight& l : scene.lights) {
        gi::VolumeLight v;
        v.position = l.position;
        v.direction = l.direction;
        // The estimated light moves every frame; a technique created with the lights is not rebuilt for it.
        v.intensity =
            l.type == render::LightType::Estimated ? glm::vec3(0.0f) : l.power / float(4.0 * std::numbers::pi);
        if (l.type == render::LightType::Spot) {
            v.cosInner = std::cos(glm::radians(l.coneAngleDegrees));
            v.cosOuter =
                std::cos(glm::radians(std::min(89.9f, l.coneAngleDegrees + std::max(l.coneFalloffDegrees, 0.01f))));
        }
        v.castsShadows = l.castsShadows;
        lights.push_back(v);
    }
    return lights;
}
} // namespace

void parseView(const std::string& text, render::DebugView& view, Overlay& overlay) {
    overlay = Overlay::None;
    view = render::DebugView::Final;
    if (text == "vals")
        overlay = Overlay::Vals;
    else if (text == "sparse")
        overlay = Overlay::SparsePoints;
    else if (text == "error")
        overlay = Overlay::ErrorVsBruteForce;
    else if (text == "vpl")
        overlay = Overlay::VertexVpls;
    else if (text == "differential")
        overlay = Overlay::Differential;
    else if (text == "light")
        overlay = Overlay::LightEstimate;
    else {
        for (auto v : {render::DebugView::Final, render::DebugView::DirectOnly, render::DebugView::IndirectOnly,
                       render::DebugView::Normals, render::DebugView::Albedo})
            if (text == render::toString(v)) {
                view = v;
                return;
            }
        throw Error("--view", std::nullopt,
                    "expected final, direct, indirect, normals, albedo, vals, sparse, error, vpl, differential or "
                    "light, got '" +
                        text + "'");
    }
}

namespace {

bool projectToPixel(const CameraIntrinsics& k, const Pose& camera_T_world, const glm::dvec3& world, cv::Point& pixel) {
    const glm::dvec3 c = camera_T_world.transformPoint(world);
    if (c.z <= 0.05) return false;
    const glm::dvec2 p = k.project(c);
    if (!(p.x >= 0 && p.y >= 0 && p.x < k.width && p.y < k.height)) return false;
    pixel = cv::Point(int(std::lround(p.x)), int(std::lround(p.y)));
    return true;
}

void drawVals(cv::Mat& image, const std::vector<gi::VirtualAreaLight>& vals, const CameraIntrinsics& k,
              const Pose& world_T_camera) {
    float brightest = 0.0f;
    for (const auto& v : vals) brightest = std::max({brightest, v.flux.x, v.flux.y, v.flux.z});
    if (!(brightest > 0.0f)) return;
    const Pose camera_T_world = world_T_camera.inverse();
    for (const auto& v : vals) {
        cv::Point pixel;
        if (!projectToPixel(k, camera_T_world, glm::dvec3(v.position), pixel)) continue;
        const glm::vec3 c = glm::sqrt(v.flux / brightest) * 255.0f; // square root: dim VALs stay visible
        cv::circle(image, pixel, 1, cv::Scalar(c.z, c.y, c.x), cv::FILLED);
    }
}

void drawSparsePoints(cv::Mat& image, const render::Renderer& renderer, const CameraIntrinsics& k,
                      const Pose& world_T_camera) {
    const Pose camera_T_world = world_T_camera.inverse();
    for (const gi::MeshInstance& instance : renderer.instances()) {
        const gi::SparsePointSet* set = renderer.sparsePoints(instance.meshId);
        if (set == nullptr) continue;
        for (const gi::SparsePoint& point : set->points) {
            const glm::vec4 world = instance.world_T_model * glm::vec4(point.position, 1.0f);
            cv::Point pixel;
            if (!projectToPixel(k, camera_T_world, glm::dvec3(world), pixel)) continue;
            cv::circle(image, pixel, 2, cv::Scalar(0, 0, 0), cv::FILLED);
            cv::circle(image, pixel, 1, cv::Scalar(0, 255, 255), cv::FILLED);
        }
    }
}

/// Clips the world segment a-b at the camera's near plane and projects it; false if it is wholly behind.
bool projectSegment(const CameraIntrinsics& k, const Pose& camera_T_world, const glm::dvec3& a, const glm::dvec3& b,
                    cv::Point& pa, cv::Point& pb) {
    constexpr double kNear = 0.05;
    glm::dvec3 ca = camera_T_world.transformPoint(a), cb = camera_T_world.transformPoint(b);
    if (ca.z <= kNear && cb.z <= kNear) return false;
    if (ca.z < kNear) ca += (cb - ca) * ((kNear - ca.z) / (cb.z - ca.z));
    if (cb.z < kNear) cb += (ca - cb) * ((kNear - cb.z) / (ca.z - cb.z));
    const auto toPixel = [&k](const glm::dvec3& c) {
        const glm::dvec2 p = glm::clamp(k.project(c), glm::dvec2(-1e6), glm::dvec2(1e6)); // cv::line clips to the image
        return cv::Point(int(std::lround(p.x)), int(std::lround(p.y)));
    };
    pa = toPixel(ca);
    pb = toPixel(cb);
    return true;
}

bool isFinite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

struct VplViewResult {
    std::int64_t drawn = 0, nonFinite = 0;
};

/// The vpl view: per-vertex interpolated diffuse VPLs (layout: LightSkinIllumination.cpp, 4 vec4 per
/// vertex: (L'''_d, rbar^2), (l'''_d world, 0), glossy...). Debug view only: the GPU->CPU readback
/// of the per-vertex buffer stalls the pipeline every frame; no other view does this.
/// Any technique whose capabilities() say vertexVpls (LightSkin on either backend: the same layout).
VplViewResult drawVertexVpls(cv::Mat& image, const gi::IndirectIllumination& technique,
                             std::span<const gi::MeshInstance> instances, const CameraIntrinsics& k,
                             const Pose& world_T_camera, std::vector<glm::vec4>& vpls) {
    VplViewResult result;
    technique.readVertexVpls(vpls);
    const std::size_t vertexCount = vpls.size() / 4;
    const std::vector<std::uint32_t>& offsets = technique.vertexOffsets();
    LIGHTSKIN_ASSERT(offsets.size() == instances.size(),
                     "lightskin::apps: the technique was prepared with other instances");
    float brightest = 0.0f;
    for (std::size_t v = 0; v < vertexCount; ++v) {
        const glm::vec3 radiance(vpls[4 * v]), position(vpls[4 * v + 1]);
        if (!isFinite(radiance) || !isFinite(position)) {
            ++result.nonFinite;
            continue;
        }
        brightest = std::max({brightest, radiance.x, radiance.y, radiance.z});
    }
    if (!(brightest > 0.0f)) return result;
    const std::size_t step = std::max<std::size_t>(1, (vertexCount + kMaxVplSegments - 1) / kMaxVplSegments);
    const Pose camera_T_world = world_T_camera.inverse();
    for (std::size_t m = 0; m < instances.size(); ++m) {
        const TriangleMesh& mesh = *instances[m].mesh;
        // one global subsampling grid over all meshes' vertices
        const std::size_t first = offsets[m];
        for (std::size_t v = (step - first % step) % step; v < mesh.vertexCount(); v += step) {
            const std::size_t g = first + v;
            LIGHTSKIN_ASSERT(g < vertexCount, "lightskin::apps: vertex outside the technique's per-vertex buffer");
            const glm::vec3 radiance(vpls[4 * g]), position(vpls[4 * g + 1]);
            if (!isFinite(radiance) || !isFinite(position)) continue;
            if (!(std::max({radiance.x, radiance.y, radiance.z}) > 0.0f)) continue; // no light: no VPL
            const glm::dvec3 vertex(instances[m].world_T_model * glm::vec4(mesh.positions[v], 1.0f));
            const glm::dvec3 vpl(position);
            cv::Point a, b;
            if (!projectSegment(k, camera_T_world, vertex, vertex + 0.25 * (vpl - vertex), a, b)) continue;
            const glm::vec3 c = glm::sqrt(glm::max(radiance, 0.0f) / brightest) * 255.0f;
            const cv::Scalar colour(c.z, c.y, c.x);
            cv::line(image, a, b, colour, 1, cv::LINE_8);
            cv::Point dot;
            if (projectToPixel(k, camera_T_world, vpl, dot)) cv::circle(image, dot, 1, colour, cv::FILLED);
            ++result.drawn;
        }
    }
    return result;
}

/// The differential view (Overlay::Differential): dE / E_without as blue (darker) / red (brighter)
/// over the camera image at 35 %.
void drawDifferential(cv::Mat& image, const cv::Mat& camera, const gi::DifferentialImages& d) {
    camera.convertTo(image, -1, 0.35);
    for (int v = 0; v < image.rows; ++v) {
        const auto* affected = d.affected.ptr<std::uint8_t>(v);
        const auto* delta = d.deltaIrradiance.ptr<cv::Vec3f>(v);
        const auto* without = d.irradianceWithout.ptr<cv::Vec3f>(v);
        auto* dst = image.ptr<cv::Vec3b>(v);
        for (int u = 0; u < image.cols; ++u) {
            if (affected[u] == 0) continue;
            const auto luminance = [](const cv::Vec3f& bgr) {
                return 0.0722f * bgr[0] + 0.7152f * bgr[1] + 0.2126f * bgr[2];
            };
            const float w = luminance(without[u]);
            const float ratio = w > 0.0f ? luminance(delta[u]) / w : 0.0f;
            const auto level = [](float x) {
                return cv::saturate_cast<std::uint8_t>(255.0f * std::clamp(x, 0.0f, 1.0f));
            };
            if (ratio < 0.0f)
                dst[u][0] = std::max(dst[u][0], level(-ratio));
            else
                dst[u][2] = std::max(dst[u][2], level(2.0f * ratio));
        }
    }
}

/// computeVpls()'s arguments for one frame: VALs in one of the pipeline's CPU generators, depth in the frame's slot.
struct GiJob {
    gi::CpuValTechnique* technique = nullptr;
    std::span<const gi::VirtualAreaLight> vals;
    std::span<const gi::MeshInstance> instances;
    glm::vec3 cameraPositionWorld{0.0f};
    gi::CpuValPixelKeys pixels;
    gi::RealDepthView realDepth;
};

/// The GI ahead (FramePipeline::render with a NextFrame). Frame n makes frame n+1's VALs (into the other CPU
/// generator) before its own GL work, and after its own GI has been shaded hands n+1's stages 0-4 to the
/// worker, which runs them while frame n shades, reads back and composites and frame n+1 starts. One job at
/// a time: the caller writes `job` only while none is pending (the mutex orders the hand-over and the end).
struct GiAhead {
    bool on = false;
    std::thread worker; // started by the first setGiAhead(true)
    std::mutex mutex;
    std::condition_variable changed;
    bool stop = false, jobReady = false, pending = false; // under the mutex; pending: handed over, not finished
    GiJob job;
    std::exception_ptr jobError; // the worker's, read after waitIdle()

    // The caller's side: what it did for the frame of PreparedFrame::sequence `sequence` under `generation`.
    enum class Stage { None, ValsReady, Launched, ValsFailed } stage = Stage::None;
    std::uint64_t sequence = 0, generation = 0, instanceSetVersion = 0;
    GiJob next;                   // ValsReady: the job launch() hands over
    std::exception_ptr valsError; // ValsFailed: thrown by that frame's render()
    double valsMs = 0.0;          // that frame's VALs and their cull, on the caller's thread

    ~GiAhead();
    void run() {
        std::unique_lock lock(mutex);
        for (;;) {
            changed.wait(lock, [&] { return stop || jobReady; });
            if (stop) return;
            jobReady = false;
            const GiJob j = job;
            lock.unlock();
            std::exception_ptr failed;
            try {
                j.technique->computeVpls(j.vals, j.instances, j.cameraPositionWorld, j.pixels, j.realDepth);
            } catch (...) {
                failed = std::current_exception();
            }
            lock.lock();
            jobError = failed;
            pending = false;
            changed.notify_all();
        }
    }
    void launch() {
        {
            const std::lock_guard lock(mutex);
            job = next;
            jobError = nullptr;
            pending = jobReady = true;
        }
        changed.notify_all();
        stage = Stage::Launched;
    }
    void waitIdle() {
        std::unique_lock lock(mutex);
        changed.wait(lock, [&] { return !pending; });
    }
    /// Waits for a running job and forgets everything.
    void drop() {
        waitIdle();
        stage = Stage::None;
        jobError = valsError = nullptr;
    }
};

} // namespace

struct FramePipeline::State {
    /// The virtual content as it is now: the scene file's, with the host's changes and, each frame, the
    /// animations' placements and light values written into world_T_model and the lights.
    render::Scene scene;
    AnimationClock clock;
    bool contentPending = false;          // the host changed a placement or light: applied at the next frame
    double contentMs = -1.0;              // this frame's placing of moving content (FrameOutput "content"), -1: none
    std::uint64_t instanceSetVersion = 0; // +1 when the instances or their materials change (not placements)
    /// The GI ahead's instances: this frame's, placed where the animations put them at the next frame's time.
    /// Two, by PreparedFrame::sequence % 2, as cpuVals: frame n's may still be read by the worker while frame n
    /// places frame n+1's.
    std::array<std::vector<gi::MeshInstance>, 2> aheadInstances;
    capture::FrameSourceInfo source;
    std::unique_ptr<gi::IndirectIllumination> technique;
    std::optional<tracking::PoseTracker> tracker;
    std::optional<roommodel::RoomMemory> roomMemory; // the scene's roomModel, with tracking and registered depth
    std::optional<gi::ValGenerator> vals;
    // The CPU backend's VALs, generated on the CPU (no GL pass, no read-back); created on first use.
    // Two, by PreparedFrame::sequence % 2: the GI ahead makes frame n+1's while frame n's are in use.
    std::array<std::optional<gi::CpuValGenerator>, 2> cpuVals;
    std::span<const gi::VirtualAreaLight> cpuValSet;
    std::optional<gi::ValOccupancyCull> occupancy; // gi.robustRealDepth
    bool valsUsable = false;
    // gi.virtualBounce with lights: RSM VALs merged after the depth VALs (all sized at creation).
    std::vector<gi::VirtualLight> virtualLights;
    std::optional<gi::ReflectiveShadowMap> rsm;
    std::optional<gi::ValSetMerger> merger;
    gl::GpuStageTimer rsmTimer;
    std::vector<gl::StageTime> rsmTimes;
    render::Compositor compositor;
    capture::BilateralDepthFilter depthFilter; // KinectFusion defaults (capture/DepthFilter.h)
    PreparedFrame prepared;                    // process()'s own front (Session's prefetch brings its own)
    cv::Mat virtualColour, virtualDepth, virtualLinear, srgbToLinearTable;
    std::unique_ptr<gi::IndirectIllumination> bruteForce; // error view only
    cv::Mat indirectTechnique, indirectReference, errorMap, normalsRgba, facing;
    std::vector<glm::vec4> vertexVpls; // vpl view only
    std::vector<gl::StageTime> scratchTimes;
    cv::Mat coverage;             // alpha of virtualColour (coveredPixels)
    int valStride = 0;            // the ValGenerator's stride
    int preparedSparsePoints = 0; // per object, as the renderer prepared them; 0 = none
    // Differential rendering (compositing.differential): receivers on the real surface, created once.
    std::optional<gi::DifferentialIrradiance> differential;
    std::vector<gi::DifferentialLightSource> differentialLights;
    std::vector<gi::VirtualAreaLight> depthValsOnCpu;
    gi::DifferentialImages differentialImages;
    cv::Mat cameraWithDifferential;
    std::uint64_t preparedCount = 0; // prepare() calls: PreparedFrame::sequence
    std::uint64_t generation = 0;    // setGiSettings() calls: a GI ahead of older settings is not used
    GiAhead giAhead;
    // A scene light of type estimated (at most one): the room's light, fitted every fitInterval-th frame that has
    // a pose, depth and virtual objects.
    std::optional<std::size_t> estimatedLight; // its index in scene.lights
    std::optional<roomlight::RoomLightEstimator> roomLight;
    std::uint64_t roomLightFrames = 0;
    /// Model-space bounding boxes (min, max) of the instances' meshes, for the estimate's reference point; cleared
    /// when the instances change.
    struct ModelBox {
        const TriangleMesh* mesh = nullptr;
        glm::vec3 lo{0.0f}, hi{0.0f};
    };
    std::vector<ModelBox> modelBoxes;
    gi::GlRenderer glRenderer = gi::GlRenderer::Unknown; // the context's, for a backend "auto"
    gi::BackendChoice backendChoice;

    /// The frame computeDifferential() reads; set before it runs, untouched by either thread until it ends.
    struct DifferentialInput {
        const cv::Mat* depthMetres = nullptr;
        const CameraIntrinsics* intrinsics = nullptr;
        const Pose* world_T_camera = nullptr;
        const cv::Mat* colour = nullptr;
    } differentialInput;
    double differentialMs = 0.0; // the last computeDifferential()'s wall time
    /// Differential rendering from differentialInput and depthValsOnCpu into differentialImages and
    /// cameraWithDifferential. Touches no GL and nothing else of the frame: it may run beside the GI.
    void computeDifferential();
    /// setDifferentialAlongside(true): the thread computeDifferential() runs on beside the frame's GL work.
    /// Last, so that it ends before the state its runs read.
    std::optional<BackgroundTask> differentialTask;
    bool differentialLaunched = false; // this frame's run is on differentialTask, not yet collected
};

void FramePipeline::State::computeDifferential() {
    const auto t = Clock::now();
    const DifferentialInput& in = differentialInput;
    differential->compute(*in.depthMetres, *in.intrinsics, *in.world_T_camera, depthValsOnCpu, differentialLights,
                          differentialImages);
    render::applyDifferentialInto(*in.colour, differentialImages, scene.exposureStops, cameraWithDifferential);
    differentialMs = msSince(t);
}

GiAhead::~GiAhead() {
    if (!worker.joinable()) return;
    {
        const std::lock_guard lock(mutex);
        stop = true;
    }
    changed.notify_all();
    worker.join();
}

FramePipeline::~FramePipeline() {
    if (state_) state_->giAhead.drop(); // its job reads the renderer's instances, destroyed before state_
}

void FramePipeline::setGiAhead(bool on) {
    GiAhead& g = state_->giAhead;
    if (!on) g.drop();
    g.on = on;
    if (on && !g.worker.joinable()) g.worker = std::thread([&g] { g.run(); });
}

void FramePipeline::finishGiAhead() { state_->giAhead.drop(); }

bool FramePipeline::hasRoomMemory() const noexcept { return state_->roomMemory.has_value(); }

namespace {
constexpr const char* kNoRoomMemory = "the session has no room memory: it needs a scene with a roomModel block, poses "
                                      "from tag tracking (pose mode tracking) and depth registered to colour";
}

void FramePipeline::saveRoomModel(const std::filesystem::path& file) const {
    if (!state_->roomMemory) throw Error(file.string(), std::nullopt, kNoRoomMemory);
    roommodel::saveRoomModel(state_->roomMemory->model(), file);
}

void FramePipeline::loadRoomModel(const std::filesystem::path& file) {
    if (!state_->roomMemory) throw Error(file.string(), std::nullopt, kNoRoomMemory);
    state_->roomMemory->loadModel(file);
}

void FramePipeline::setDifferentialAlongside(bool on) {
    State& s = *state_;
    if (!on)
        s.differentialTask.reset(); // between frames: no run pending
    else if (!s.differentialTask)
        s.differentialTask.emplace([&s] { s.computeDifferential(); });
}

std::unique_ptr<FramePipeline> FramePipeline::create(const render::Scene& scene, const capture::FrameSourceInfo& source,
                                                     const PipelineOptions& options) {
    std::unique_ptr<FramePipeline> p(new FramePipeline());
    p->state_ = std::make_unique<State>();
    State& s = *p->state_;
    s.scene = scene;
    s.source = source;
    p->options_ = options;
    p->gi_ = scene.gi;
    const CameraIntrinsics& colour = source.colourIntrinsics;
    if (!colour.isValid()) throw Error(source.uri, std::nullopt, "the source has no valid colour intrinsics");
    p->renderer_ = render::Renderer::create(colour);
    const bool sparsePoints = gi::needsSparsePoints(scene.gi.technique);
    p->renderer_->setScene(scene, sparsePoints);
    s.preparedSparsePoints = sparsePoints ? scene.gi.sparsePoints : 0;
    s.compositor = render::Compositor::create(colour, scene.compositing);
    // Built and checked under every pose mode (a bad /tracking is said up front); kept only when tracking.
    s.tracker = trackerFromScene(scene, options.poseMode == PoseMode::Tracking);
    if (options.poseMode != PoseMode::Tracking) s.tracker.reset();

    // VALs need depth and colour of one size, registered (the ValGenerator's contract).
    s.valsUsable = source.registration == DepthRegistration::RegisteredToColour &&
                   source.depthIntrinsics.width == colour.width && source.depthIntrinsics.height == colour.height;
    s.roomMemory = roomMemoryFromScene(scene, options.poseMode, s.valsUsable, source.uri);
    if (!options.roomModelFile.empty()) {
        p->loadRoomModel(options.roomModelFile);
        log::info(options.roomModelFile.string() + ": room model loaded (" +
                  std::to_string(s.roomMemory->model().views().size()) + " views)");
    }
    if (s.valsUsable) {
        p->createValGenerator(scene.gi.valStride);
        s.occupancy = gi::ValOccupancyCull::create(colour.width, colour.height);
    } else {
        log::warning(source.uri + ": depth is not registered to colour; no VALs and no occlusion by real geometry");
    }
    if (scene.gi.virtualBounce && scene.gi.technique == gi::Technique::MultiscalePrt)
        log::warning("gi.virtualBounce with technique multiscale-prt: the lights' bounce between the virtual objects "
                     "is counted twice (RSM VALs and the precomputed transfer); turn virtualBounce off");
    if (scene.gi.virtualBounce && scene.lights.empty())
        log::info("gi.virtualBounce: the scene has no lights, nothing to bounce");
    if (scene.gi.virtualBounce && !scene.lights.empty()) {
        s.virtualLights = virtualLightsFromScene(scene);
        gi::RsmSettings rsm;
        rsm.resolution = scene.gi.rsmResolution;
        rsm.maxLights = int(s.virtualLights.size());
        s.rsm = gi::ReflectiveShadowMap::create(rsm);
        // Depth VALs first, then every RSM texel of every light face: nothing can be dropped.
        const std::uint32_t depthCapacity = s.vals ? s.vals->capacity() : 0u;
        s.merger = gi::ValSetMerger::create(depthCapacity + s.rsm->capacity());
        s.rsmTimer = gl::GpuStageTimer::create(1);
        log::info("gi.virtualBounce: " + std::to_string(s.virtualLights.size()) + " light(s), RSM " +
                  std::to_string(rsm.resolution) + "^2 per face, " + std::to_string(s.merger->capacity()) +
                  " VALs merged at most");
    }
    for (std::size_t i = 0; i < scene.lights.size(); ++i) {
        const render::SceneLight& light = scene.lights[i];
        if (light.type != render::LightType::Estimated) continue;
        roomlight::RoomLightOptions o;
        o.stride = light.estimation.stride;
        o.timeConstantSeconds = light.estimation.timeConstantSeconds;
        o.referenceAlbedo = light.estimation.referenceAlbedo;
        s.estimatedLight = i;
        s.roomLight.emplace(o);
        if (!s.valsUsable)
            log::warning(source.uri + ": the estimated light needs depth registered to colour; it stays dark");
    }
    if (options.overlay == Overlay::LightEstimate && !s.roomLight)
        throw Error(
            "--view", std::nullopt,
            "light: the scene has no light of type \"estimated\" (docs/SCENE_FORMAT.md), so no estimate to show");
    p->rebuildDifferential();
    const auto* glRenderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    s.glRenderer = gi::classifyGlRenderer(glRenderer != nullptr ? glRenderer : "");
    p->setGiSettings(scene.gi);
    log::info("GI backend: " + std::string(gi::toString(s.backendChoice.backend)) + " (" +
              std::string(gi::toString(s.backendChoice.reason)) + ")");
    gl::DebugOutput::throwIfErrors("pipeline creation");
    return p;
}

void FramePipeline::downloadDepthValsInto(std::vector<gi::VirtualAreaLight>& vals,
                                          std::vector<std::uint32_t>& pixels) const {
    vals.clear();
    pixels.clear();
    if (!state_->vals) return;
    vals = state_->vals->downloadVals();
    pixels = state_->vals->downloadPixelIndices();
}

void FramePipeline::createValGenerator(int stride) {
    State& s = *state_;
    const CameraIntrinsics& colour = s.source.colourIntrinsics;
    gi::ValGeneratorSettings settings;
    settings.stride = stride;
    // The camera's exposure: a linear pixel value p is radiance p / 2^exposureStops.
    settings.exposure = std::exp2(-s.scene.exposureStops);
    settings.skipUnchangedInput = options_.adaptive; // keeps the VAL generation for a paused recording
    s.vals = gi::ValGenerator::create(colour.width, colour.height, settings);
    s.valStride = stride;
    if (s.merger) s.merger = gi::ValSetMerger::create(s.vals->capacity() + s.rsm->capacity());
}

void FramePipeline::setGiSettings(const render::GiSettings& settings) {
    State& st = *state_;
    st.giAhead.drop(); // it uses the technique and the VAL generator replaced below
    ++st.generation;
    // A new VAL stride needs a generator of that size; new sparse points need the meshes prepared
    // again (Renderer::setScene: the sparse points may refine the meshes). Both are rare (the frame
    // budget switches with hysteresis), not per frame.
    if (st.vals && settings.valStride != st.valStride) createValGenerator(settings.valStride);
    if (gi::needsSparsePoints(settings.technique) && settings.sparsePoints != st.preparedSparsePoints) {
        render::Scene scene = st.scene;
        scene.gi.sparsePoints = settings.sparsePoints;
        renderer_->setScene(scene, true);
        st.modelBoxes.clear(); // the meshes were loaded again
        st.preparedSparsePoints = settings.sparsePoints;
        st.bruteForce.reset(); // prepared for the old instances
    }
    // gi_ keeps the setting ("auto" too): each call resolves it again, so a frame budget's brute force returns
    // to the backend LightSkin had, and the choice keeps its reason.
    st.backendChoice = gi::chooseBackend(settings.technique, settings.backend, options_.backend, st.glRenderer);
    gi_ = settings;
    render::GiSettings resolved = settings;
    resolved.backend = gi::settingOf(st.backendChoice.backend);
    const gi::AdaptiveOptions adaptive{.on = options_.adaptive,
                                       .staticTolerance = options_.staticTolerance,
                                       .staticChangeTest = options_.staticProbes ? gi::StaticChangeTest::Probes
                                                                                 : gi::StaticChangeTest::Bound};
    gi::TechniqueConfig config = gi::configFor(resolved, adaptive);
    // Imperfect volumes' mesh points carry the scene lights' direct light, shadowed by the renderer's own
    // shadow maps; multi-scale PRT takes them at its entry points (lights are static: set once per technique).
    config.volumeLights = volumeLightsFromScene(st.scene);
    config.volumeShadowCubes = renderer_->shadowMapTexture();
    config.prtLights = prtLightsFromScene(st.scene);
    refuseDeformationFor(settings.technique);
    st.technique = gi::createTechnique(config, sparsePointsOf(*renderer_));
    // A scene without virtual objects is valid (the real room alone): GI has nothing to light and stays
    // idle (runGi), so the technique is not prepared for nothing.
    if (!renderer_->instances().empty()) st.technique->prepare(renderer_->instances());
}

// ---- moving content ------------------------------------------------------------------------------

void FramePipeline::rebuildDifferential() {
    State& s = *state_;
    s.differential.reset();
    s.differentialLights.clear();
    if (!(s.scene.compositing.differential && s.valsUsable && !renderer_->instances().empty())) return;
    s.differential = gi::DifferentialIrradiance::create(renderer_->instances());
    const std::vector<gi::VirtualLight> lights = virtualLightsFromScene(s.scene);
    for (std::size_t i = 0; i < lights.size(); ++i)
        s.differentialLights.push_back({lights[i], s.scene.lights[i].inRoom});
}

namespace {
bool animated(const render::Scene& scene) {
    return std::any_of(scene.objects.begin(), scene.objects.end(),
                       [](const auto& o) { return render::isAnimated(o); }) ||
           std::any_of(scene.lights.begin(), scene.lights.end(), [](const auto& l) { return l.animation.has_value(); });
}
} // namespace

void FramePipeline::applyContentAt(double timeSeconds) {
    State& s = *state_;
    s.contentMs = -1.0;
    if (!s.contentPending && !animated(s.scene)) return;
    const auto start = Clock::now();
    s.contentPending = false;
    // A GI ahead may run on: its job reads its own copy of the instances (aheadInstances), not the renderer's.
    sampleAnimations(s.scene, timeSeconds);
    bool moved = false;
    for (std::size_t i = 0; i < s.scene.objects.size(); ++i)
        moved = renderer_->setObjectPlacement(i, s.scene.objects[i].world_T_model) || moved;
    // The GI ahead's job reads the meshes in place: it must end before their vertices change.
    const bool deforming = renderer_->hasDeformingObjects();
    if (deforming) s.giAhead.drop();
    const bool deformed = deforming && renderer_->deformAt(timeSeconds);
    const bool lightsChanged = renderer_->setLights(s.scene.lights);
    if (moved || deformed) contentMoved(deformed);
    if (lightsChanged) lightsMoved();
    s.contentMs = msSince(start);
}

namespace {
bool samePlacements(std::span<const gi::MeshInstance> a, std::span<const gi::MeshInstance> b) {
    return std::equal(a.begin(), a.end(), b.begin(), b.end(), [](const gi::MeshInstance& x, const gi::MeshInstance& y) {
        return x.meshId == y.meshId && x.mesh == y.mesh && x.world_T_model == y.world_T_model;
    });
}
} // namespace

std::span<const gi::MeshInstance> FramePipeline::placeForNextFrame(const RgbdFrame& nextFrame, std::uint64_t sequence) {
    State& s = *state_;
    const std::span<const gi::MeshInstance> now = renderer_->instances();
    std::vector<gi::MeshInstance>& placed = s.aheadInstances[sequence % 2];
    placed.assign(now.begin(), now.end()); // capacity kept: no allocation once grown
    if (!animated(s.scene)) return placed;
    const double t = s.clock.timeOf(nextFrame);
    for (gi::MeshInstance& instance : placed) {
        const render::SceneObject& object = s.scene.objects[renderer_->sceneObjectOf(instance.meshId)];
        if (render::isAnimated(object)) instance.world_T_model = render::placementAt(object, t);
    }
    return placed;
}

void FramePipeline::contentMoved(bool deformed) {
    State& s = *state_;
    if (s.differential) s.differential->place(renderer_->instances()); // its occluders (the vertices) and emitters
    if (deformed) {
        s.modelBoxes.clear(); // the deformed meshes' boxes
        s.bruteForce.reset(); // the budget's brute force: prepared for the old vertices
    }
    // Every technique but multi-scale PRT (refused: refuseDeformationFor) prepares model-space copies of the
    // meshes and sparse points: after a deformation, prepared again from the deformed ones.
    if ((deformed || s.technique->capabilities().placementInPrepare) && !renderer_->instances().empty()) {
        s.giAhead.drop();
        s.technique->prepare(renderer_->instances());
    }
}

void FramePipeline::refuseDeformationFor(gi::Technique technique) const {
    if (technique != gi::Technique::MultiscalePrt) return;
    const auto& objects = state_->scene.objects;
    for (std::size_t i = 0; i < objects.size(); ++i)
        if (objects[i].skinAnimation)
            throw Error(sourceName(), std::nullopt,
                        "/objects/" + std::to_string(i) + " ('" + objects[i].name +
                            "'): a skinned mesh deforms, and multi-scale PRT precomputes its transfer for fixed "
                            "geometry: it cannot follow the deformation (use lightskin, brute-force or "
                            "imperfect-volumes)");
}

void FramePipeline::lightsMoved() {
    State& s = *state_;
    const std::vector<gi::VirtualLight> lights = virtualLightsFromScene(s.scene);
    if (s.rsm) s.virtualLights = lights;
    for (std::size_t i = 0; i < s.differentialLights.size(); ++i) s.differentialLights[i].light = lights[i];
    if (s.technique->capabilities().sceneLightsAtCreation) setGiSettings(gi_); // created with the new lights
}

void FramePipeline::instancesChanged() {
    State& s = *state_;
    s.modelBoxes.clear();
    s.giAhead.drop(); // its job reads the old instances
    ++s.instanceSetVersion;
    s.bruteForce.reset(); // prepared for the old instances
    rebuildDifferential();
    if (!renderer_->instances().empty()) s.technique->prepare(renderer_->instances());
}

const render::Scene& FramePipeline::scene() const noexcept { return state_->scene; }

std::string FramePipeline::sourceName() const {
    return state_->scene.file.empty() ? std::string("scene") : state_->scene.file.string();
}

void FramePipeline::checkObjectIndex(std::size_t object) const {
    const std::size_t count = state_->scene.objects.size();
    if (object >= count)
        throw Error(sourceName(), std::nullopt,
                    "object " + std::to_string(object) + ": no such object (the scene has " + std::to_string(count) +
                        ")");
}

void FramePipeline::setObjectTransform(std::size_t object, const glm::mat4& world_T_model) {
    checkObjectIndex(object);
    checkPlacement(world_T_model, sourceName(), "object " + std::to_string(object));
    render::SceneObject& o = state_->scene.objects[object];
    o.animation.reset(); // the host drives it from now on
    o.gltfAnimation.reset();
    o.world_T_model = world_T_model;
    state_->contentPending = true;
}

void FramePipeline::setObjectVisible(std::size_t object, bool visible) {
    checkObjectIndex(object);
    state_->giAhead.drop(); // its job reads the renderer's instances
    state_->scene.objects[object].visible = visible;
    if (renderer_->setObjectVisible(object, visible)) instancesChanged();
}

void FramePipeline::setObjectMaterial(std::size_t object, const render::MaterialOverride& material) {
    checkObjectIndex(object);
    checkMaterial(material, sourceName(), "object " + std::to_string(object));
    render::MaterialOverride& m = state_->scene.objects[object].material;
    m.diffuseAlbedo = material.diffuseAlbedo;
    m.specularAlbedo = material.specularAlbedo;
    m.specularExponent = material.specularExponent;
    state_->giAhead.drop(); // its job reads the renderer's instances
    renderer_->setObjectMaterial(object, m);
    ++state_->instanceSetVersion;
    if (state_->differential) state_->differential->place(renderer_->instances()); // its emitters' albedo
}

void FramePipeline::setLight(std::size_t light, const glm::vec3& position, const glm::vec3& direction,
                             const glm::vec3& power) {
    State& s = *state_;
    const std::string what = "light " + std::to_string(light);
    if (light >= s.scene.lights.size())
        throw Error(sourceName(), std::nullopt,
                    what + ": no such light (the scene has " + std::to_string(s.scene.lights.size()) + ")");
    render::SceneLight l = s.scene.lights[light];
    if (l.type == render::LightType::Estimated)
        throw Error(sourceName(), std::nullopt,
                    what + ": the light of type estimated follows the room's light every frame; it cannot be set");
    l.position = position;
    l.power = power;
    if (l.type == render::LightType::Spot) l.direction = direction;
    checkLightValues(l, sourceName(), what);
    if (l.type == render::LightType::Spot) l.direction = glm::normalize(l.direction);
    l.animation.reset(); // the host drives it from now on
    s.scene.lights[light] = l;
    s.contentPending = true;
}

std::size_t FramePipeline::addObject(render::SceneObject object) {
    State& s = *state_;
    const std::string what = "new object '" + object.name + "'";
    if (object.name.empty()) throw Error(sourceName(), std::nullopt, "new object: a name is required");
    if (object.animation && object.animation->keys.empty())
        throw Error(sourceName(), std::nullopt, what + ": an animation needs at least one key");
    checkPlacement(render::placementAt(object, 0.0), sourceName(), what);
    checkMaterial(object.material, sourceName(), what);
    if (!std::filesystem::is_regular_file(object.mesh))
        throw Error(object.mesh.string(), std::nullopt, what + ": the mesh file does not exist");
    if (object.material.diffuseTexture && !std::filesystem::is_regular_file(*object.material.diffuseTexture))
        throw Error(object.material.diffuseTexture->string(), std::nullopt, what + ": the texture file does not exist");
    if (object.skinAnimation && s.technique->technique() == gi::Technique::MultiscalePrt)
        throw Error(sourceName(), std::nullopt,
                    what + ": a skinned mesh deforms, and multi-scale PRT cannot follow the deformation");
    s.giAhead.drop();                                   // its job reads the renderer's instances
    renderer_->addObject(object, object.mesh.string()); // throws before changing anything
    s.scene.objects.push_back(std::move(object));
    instancesChanged();
    return s.scene.objects.size() - 1;
}

void FramePipeline::removeObject(std::size_t object) {
    checkObjectIndex(object);
    state_->giAhead.drop(); // its job reads the renderer's instances
    renderer_->removeObject(object);
    state_->scene.objects.erase(state_->scene.objects.begin() + std::ptrdiff_t(object));
    instancesChanged();
}

std::string FramePipeline::techniqueName() const { return std::string(state_->technique->name()); }

gi::Technique FramePipeline::technique() const noexcept { return state_->technique->technique(); }
gi::Backend FramePipeline::backend() const noexcept { return state_->technique->backend(); }
const gi::BackendChoice& FramePipeline::backendChoice() const noexcept { return state_->backendChoice; }

std::optional<gi::PrtPrepareStats> FramePipeline::prtPrepareStats() const {
    return gi::prtPrepareStatsOf(*state_->technique);
}

void FramePipeline::process(const RgbdFrame& frame, FrameOutput& out) {
    const auto frameStart = Clock::now();
    prepare(frame, state_->prepared);
    render(frame, state_->prepared, out);
    out.totalMs = msSince(frameStart); // the front included
}

void FramePipeline::prepare(const RgbdFrame& frame, PreparedFrame& prepared) {
    State& s = *state_;
    // Depth in metres (CV_32FC1, 0 = missing), registered to colour.
    auto t = Clock::now();
    prepared.haveDepth = frame.hasDepth() && s.valsUsable && frame.depth.cols == frame.colour.cols &&
                         frame.depth.rows == frame.colour.rows;
    if (prepared.haveDepth) s.depthFilter.filterInto(frame.depth, frame.depthScaleMetres, prepared.depthMetres);
    prepared.filterMs = msSince(t);
    prepared.roomMemoryMs = -1.0;

    t = Clock::now();
    switch (options_.poseMode) {
    case PoseMode::GroundTruth:
        prepared.tracking = tracking::PoseTracker::fromGroundTruth(frame);
        break;
    case PoseMode::Tracking:
        s.tracker->trackInto(frame, prepared.tracking);
        break;
    case PoseMode::Fixed:
        prepared.tracking = tracking::TrackingResult{};
        prepared.tracking.frameIndex = frame.index;
        prepared.tracking.state = tracking::TrackingState::Tracking;
        prepared.tracking.world_T_camera = Pose();
        break;
    }
    prepared.poseMs = msSince(t);
    if (s.roomMemory && prepared.haveDepth) { // fuses tag-tracked frames, tracks the others by depth
        t = Clock::now();
        s.roomMemory->update(prepared.depthMetres, frame.colourIntrinsics, prepared.tracking);
        prepared.roomMemoryMs = msSince(t);
    }
    prepared.sequence = ++s.preparedCount;
}

void FramePipeline::render(const RgbdFrame& frame, const PreparedFrame& prepared, FrameOutput& out) {
    render(frame, prepared, out, nullptr);
}

/// One frame's state between the stages of render(), in the order they fill it.
struct FramePipeline::FrameWork {
    FrameWork(const RgbdFrame& f, const PreparedFrame& p, FrameOutput& o)
        : frame(f)
        , prepared(p)
        , out(o) {}
    const RgbdFrame& frame;
    const PreparedFrame& prepared;
    FrameOutput& out;
    Clock::time_point start = Clock::now();
    Clock::time_point compositeStart;
    std::size_t usedTimes = 0; // entries of out.cpuTimes written
    const Pose* world_T_camera = nullptr;
    // VALs
    bool runGi = false, runDifferential = false;
    gi::CpuValTechnique* cpuTechnique = nullptr; // the technique's CPU VAL input, when GI runs
    bool valsOnCpu = false;                      // the VALs come from the CPU generator this frame
    bool useAhead = false;                       // this frame's VALs and stages 0-4 were made ahead
    gi::CpuValGenerator* frameVals = nullptr;    // this frame's CPU VALs
    gi::ValSetView valSet;
    bool gbufferReady = false, depthOnGpu = false;
    // GI and composite
    bool rsmTimed = false, stageTimesTaken = false;
    const cv::Mat* camera = nullptr;     // the camera image the composites use (with the differential, if any)
    double differentialHandOverMs = 0.0; // the depth VALs to the CPU for the differential
    cv::Mat realDepth;
    render::ShadeOptions shade;
};

void FramePipeline::render(const RgbdFrame& frame, const PreparedFrame& prepared, FrameOutput& out, NextFrame* next) {
    // A stage that throws while the differential runs beside it must not leave that run reading the frame.
    struct CollectDifferential {
        State& s;
        ~CollectDifferential() {
            if (std::exchange(s.differentialLaunched, false)) s.differentialTask->waitQuietly();
        }
    } collect{*state_};
    FrameWork w(frame, prepared, out);
    applyContentAt(state_->clock.timeOf(frame));
    beginFrame(w);
    if (!out.world_T_camera) {
        passThrough(w);
        return;
    }
    w.world_T_camera = &*out.world_T_camera;
    estimateRoomLight(w);
    makeVals(w);
    startDifferential(w);
    addVirtualBounceVals(w);
    explainGiActivity(w);
    makeNextFrameVals(w, next);
    renderGi(w);
    finishDifferential(w);
    composite(w);
    renderReferenceIndirect(w);
    drawOverlays(w);
    if (options_.compare) compositeWithoutGi(w);
    addTime(out.cpuTimes, w.usedTimes, "shade+composite", msSince(w.compositeStart));
    collectStageTimes(w);
    out.totalMs = msSince(w.start);
}

// Capture, filter and pose: the prepared frame's results and their times; every per-frame output reset.
void FramePipeline::beginFrame(FrameWork& w) {
    FrameOutput& out = w.out;
    out.frameIndex = w.frame.index;
    out.valCount = 0;
    out.giActive = false;
    out.giInactiveCause = nullptr;
    out.rsmValCount = -1;
    out.valsDropped = -1;
    out.meanRelativeErrorVsBruteForce = -1.0;
    out.vplSegments = -1;
    out.vplNonFinite = -1;
    out.giComputedAhead = false;
    out.giReused = -1;
    out.giChangeMeasure = -1.0f;
    out.volumeVoxelsDropped = -1;
    out.linearNanPixels = 0;
    out.linearInfPixels = 0;
    out.coveredPixels = 0;
    out.lightEstimate.reset();
    out.roomLightFitted = false;
    out.estimatedLight = {};
    out.roomLightCpuMs = -1.0;
    if (!out.linearIndirect.empty()) out.linearIndirect.setTo(cv::Scalar::all(0)); // keeps the buffer, no stale light
    if (!out.linearIndirectReference.empty()) out.linearIndirectReference.setTo(cv::Scalar::all(0));
    if (!out.coverage.empty()) out.coverage.setTo(cv::Scalar::all(0));
    addTime(out.cpuTimes, w.usedTimes, "depth filter", w.prepared.filterMs);
    out.tracking = w.prepared.tracking;
    out.world_T_camera = out.tracking.world_T_camera;
    addTime(out.cpuTimes, w.usedTimes, "pose", w.prepared.poseMs);
    if (w.prepared.roomMemoryMs >= 0.0) addTime(out.cpuTimes, w.usedTimes, "room memory", w.prepared.roomMemoryMs);
    if (state_->contentMs >= 0.0) addTime(out.cpuTimes, w.usedTimes, "content", state_->contentMs);
}

// Lost: nothing virtual can be placed; the frame passes through unchanged.
void FramePipeline::passThrough(FrameWork& w) {
    State& s = *state_;
    FrameOutput& out = w.out;
    out.giInactiveCause = kGiCauseNoPose;
    w.frame.colour.copyTo(out.withGi);
    if (options_.compare) w.frame.colour.copyTo(out.withoutGi);
    if (s.srgbToLinearTable.empty()) {
        s.srgbToLinearTable.create(1, 256, CV_32FC1);
        for (int i = 0; i < 256; ++i) s.srgbToLinearTable.at<float>(0, i) = eval::srgbToLinear(float(i) / 255.0f);
    }
    if (options_.linearComposite) cv::LUT(w.frame.colour, s.srgbToLinearTable, out.linearWithGi);
    out.cpuTimes.resize(w.usedTimes);
    out.gpuTimes.clear();
    out.totalMs = msSince(w.start);
}

// The CPU VALs of the frame `sequence` (this frame's, or the next one's for the GI ahead) into its generator,
// culled where the virtual content is (gi.robustRealDepth; the view's clip_T_world as renderGBuffer() sets it).
gi::CpuValGenerator& FramePipeline::generateCpuVals(std::uint64_t sequence, const RgbdFrame& frame,
                                                    const cv::Mat& depth, const Pose& pose,
                                                    std::span<const gi::MeshInstance> instances, int threads) {
    State& s = *state_;
    render::Renderer& r = *renderer_;
    std::optional<gi::CpuValGenerator>& generator = s.cpuVals[sequence % 2];
    gi::ValGeneratorSettings settings = s.vals->settings();
    settings.skipUnchangedInput = false;
    if (!generator || generator->settings().stride != settings.stride)
        generator = gi::CpuValGenerator::create(frame.colour.cols, frame.colour.rows, settings, threads);
    else
        generator->setSettings(settings);
    generator->generate(depth, 1.0, frame.colour, frame.colourIntrinsics, pose);
    if (gi_.robustRealDepth && s.occupancy)
        s.occupancy->applyOnCpu(generator->mutableLastVals(), generator->lastPixelIndices(), instances,
                                r.clipFromWorldAt(pose), pose.inverse().matrixFloat());
    return *generator;
}

// VALs from the depth map: on the CPU for a technique that takes them there (unless a GL consumer of the VAL
// buffer runs this frame: occupancy cull, RSM merge, brute-force views, the VAL overlay), else on GL.
void FramePipeline::makeVals(FrameWork& w) {
    State& s = *state_;
    render::Renderer& r = *renderer_;
    const auto t = Clock::now();
    const bool haveDepth = w.prepared.haveDepth;
    w.runGi = options_.giEnabled && gi_.technique != gi::Technique::None && !renderer_->instances().empty();
    w.runDifferential = options_.differential && s.differential && haveDepth && s.vals;
    w.cpuTechnique = w.runGi ? s.technique->cpuValInput() : nullptr;
    w.valsOnCpu = w.cpuTechnique && !s.rsm && !options_.referenceIndirect &&
                  options_.overlay != Overlay::ErrorVsBruteForce && options_.overlay != Overlay::Vals;
    // The GI ahead made this frame's VALs and started its GI with this frame's settings (the worker may still
    // run it: it only reads the VALs, the GI stage waits for it). Any other job must end before this frame
    // touches the technique or a VAL generator.
    GiAhead& ahead = s.giAhead;
    const bool aheadForThisFrame =
        (ahead.stage == GiAhead::Stage::Launched || ahead.stage == GiAhead::Stage::ValsFailed) &&
        ahead.sequence == w.prepared.sequence && ahead.generation == s.generation &&
        ahead.instanceSetVersion == s.instanceSetVersion &&
        samePlacements(s.aheadInstances[w.prepared.sequence % 2], renderer_->instances());
    w.useAhead = aheadForThisFrame && haveDepth && w.valsOnCpu && s.vals && s.cpuVals[w.prepared.sequence % 2] &&
                 options_.overlay != Overlay::VertexVpls;
    if (!w.useAhead) ahead.waitIdle();
    ahead.stage = GiAhead::Stage::None;
    if (w.useAhead && ahead.valsError) std::rethrow_exception(std::exchange(ahead.valsError, nullptr));
    w.out.giComputedAhead = w.useAhead;
    s.cpuValSet = {};
    if (haveDepth && w.valsOnCpu && s.vals) {
        w.frameVals = w.useAhead ? &*s.cpuVals[w.prepared.sequence % 2]
                                 : &generateCpuVals(w.prepared.sequence, w.frame, w.prepared.depthMetres,
                                                    *w.world_T_camera, r.instances(), w.cpuTechnique->threads());
        s.cpuValSet = w.frameVals->lastVals();
        w.valSet = gi::ValSetView{0, std::uint32_t(s.cpuValSet.size()), 0, 0, 0};
        w.out.valCount = w.valSet.count;
    } else if (haveDepth && (w.runGi || w.runDifferential) && s.vals) {
        w.valSet =
            s.vals->generate(w.prepared.depthMetres, 1.0, w.frame.colour, w.frame.colourIntrinsics, *w.world_T_camera);
        w.out.valCount = w.valSet.count;
        w.depthOnGpu = true;
        if (gi_.robustRealDepth && s.occupancy) {
            // The VALs whose space the virtual content occupies (gi/common/ValOccupancyCull.h); needs the view.
            r.renderGBuffer(*w.world_T_camera);
            w.gbufferReady = true;
            s.occupancy->apply(w.valSet, r.instances(), r.viewParameters().clip_T_world,
                               w.world_T_camera->inverse().matrixFloat());
        }
    }
    // With the GI ahead: the time the VALs took then (this thread's wait for the GI goes to "gbuffer+gi").
    addTime(w.out.cpuTimes, w.usedTimes, "vals", w.useAhead ? ahead.valsMs : msSince(t));
}

namespace {
/// Centre of the world-space bounding box of the instances (each mesh's model box, placed), metres.
template <class Boxes>
std::optional<glm::dvec3> instancesCentre(std::span<const gi::MeshInstance> instances, Boxes& boxes) {
    glm::vec3 lo(std::numeric_limits<float>::infinity()), hi(-std::numeric_limits<float>::infinity());
    for (const gi::MeshInstance& instance : instances) {
        if (instance.mesh == nullptr || instance.mesh->positions.empty()) continue;
        auto box = std::find_if(boxes.begin(), boxes.end(), [&](const auto& b) { return b.mesh == instance.mesh; });
        if (box == boxes.end()) { // once per mesh (grows only when the instances change)
            boxes.push_back({instance.mesh, instance.mesh->positions[0], instance.mesh->positions[0]});
            box = boxes.end() - 1;
            for (const glm::vec3& p : instance.mesh->positions) {
                box->lo = glm::min(box->lo, p);
                box->hi = glm::max(box->hi, p);
            }
        }
        for (int corner = 0; corner < 8; ++corner) {
            const glm::vec3 p((corner & 1) != 0 ? box->hi.x : box->lo.x, (corner & 2) != 0 ? box->hi.y : box->lo.y,
                              (corner & 4) != 0 ? box->hi.z : box->lo.z);
            const glm::vec3 world(instance.world_T_model * glm::vec4(p, 1.0f));
            lo = glm::min(lo, world);
            hi = glm::max(hi, world);
        }
    }
    if (!(lo.x <= hi.x)) return std::nullopt;
    return glm::dvec3(0.5f * (lo + hi));
}
} // namespace

// The room's light (a scene light of type estimated): fitted every fitInterval-th frame on the registered depth and
// colour at the objects' centre, then the estimated light's position and power (EstimatedLight.h) into the scene,
// the renderer (shadow maps follow in renderGBuffer), the RSM and the differential's lights.
void FramePipeline::estimateRoomLight(FrameWork& w) {
    State& s = *state_;
    FrameOutput& out = w.out;
    if (!s.roomLight || !w.prepared.haveDepth) return;
    const std::optional<glm::dvec3> centre = instancesCentre(renderer_->instances(), s.modelBoxes);
    if (!centre) return; // nothing to light
    const auto t = Clock::now();
    const double cpuStart = threadCpuMs();
    render::SceneLight& light = s.scene.lights[*s.estimatedLight];
    out.roomLightFitted = s.roomLightFrames++ % std::uint64_t(light.estimation.fitInterval) == 0;
    if (out.roomLightFitted) s.roomLight->estimate(w.frame, *w.world_T_camera, centre);
    out.lightEstimate = s.roomLight->last();
    out.estimatedLight = estimatedDirectLight(*out.lightEstimate, light.estimation, s.scene.exposureStops);
    light.position = out.estimatedLight.positionWorld;
    light.power = out.estimatedLight.power;
    if (renderer_->setLights(s.scene.lights)) {
        // Not lightsMoved(): the techniques created with the scene's lights leave the estimated light out.
        const gi::VirtualLight v = virtualLightOf(light);
        if (s.rsm) s.virtualLights[*s.estimatedLight] = v;
        if (*s.estimatedLight < s.differentialLights.size()) s.differentialLights[*s.estimatedLight].light = v;
    }
    out.roomLightCpuMs = threadCpuMs() - cpuStart;
    addTime(out.cpuTimes, w.usedTimes, "roomlight", msSince(t));
}

// Differential rendering: the camera image with the virtual objects' shadows and bounce. The depth VALs come to
// the CPU here (a read-back needs the GL context); the rest runs beside the GI with setDifferentialAlongside.
void FramePipeline::startDifferential(FrameWork& w) {
    State& s = *state_;
    w.out.differentialReceivers = -1;
    w.out.differentialPixels = -1;
    w.camera = &w.frame.colour;
    if (!w.runDifferential) return;
    const auto t = Clock::now();
    if (w.valSet.buffer == 0 && w.valSet.count > 0) // generated on the CPU (no allocation once grown)
        s.depthValsOnCpu.assign(s.cpuValSet.begin(), s.cpuValSet.end());
    else
        gi::downloadValsInto(w.valSet, s.depthValsOnCpu);
    s.differentialInput = {&w.prepared.depthMetres, &w.frame.colourIntrinsics, w.world_T_camera, &w.frame.colour};
    w.camera = &s.cameraWithDifferential;
    w.differentialHandOverMs = msSince(t);
    if (s.differentialTask) {
        s.differentialTask->launch();
        s.differentialLaunched = true;
    } else
        s.computeDifferential();
}

// The differential's images for the composites: its run collected (the wait is the stage "differential wait").
void FramePipeline::finishDifferential(FrameWork& w) {
    State& s = *state_;
    if (!w.runDifferential) return;
    if (std::exchange(s.differentialLaunched, false)) {
        const auto t = Clock::now();
        s.differentialTask->wait();
        addTime(w.out.cpuTimes, w.usedTimes, "differential wait", msSince(t));
    }
    addTime(w.out.cpuTimes, w.usedTimes, "differential", w.differentialHandOverMs + s.differentialMs);
    w.out.differentialReceivers = s.differentialImages.receiversGathered;
    w.out.differentialPixels = cv::countNonZero(s.differentialImages.affected);
}

// VALs from the virtual lights (one bounce between virtual objects), after the depth VALs.
void FramePipeline::addVirtualBounceVals(FrameWork& w) {
    State& s = *state_;
    if (!(w.runGi && gi_.virtualBounce && s.rsm)) return;
    const auto t = Clock::now();
    s.rsmTimer.beginFrame();
    s.rsmTimer.begin("rsm");
    const gi::ValSetView sets[2] = {w.valSet, s.rsm->generate(s.virtualLights, renderer_->instances())};
    w.valSet = s.merger->merge(sets);
    s.rsmTimer.end();
    w.rsmTimed = true;
    w.out.rsmValCount = sets[1].count;
    w.out.valsDropped = s.merger->lastDropped();
    if (w.out.valsDropped > 0)
        log::warning("frame " + std::to_string(w.frame.index) + ": " + std::to_string(w.out.valsDropped) + " of " +
                     std::to_string(sets[0].count + sets[1].count) + " VALs dropped (merged set full)");
    addTime(w.out.cpuTimes, w.usedTimes, "rsm", msSince(t));
}

// Say when GI does nothing this frame, and why (reports and the console show it).
void FramePipeline::explainGiActivity(FrameWork& w) {
    const State& s = *state_;
    FrameOutput& out = w.out;
    out.giActive = w.runGi && w.valSet.count > 0;
    if (out.giActive) return;
    if (!options_.giEnabled)
        out.giInactiveCause = kGiCauseSwitchedOff;
    else if (renderer_->instances().empty())
        out.giInactiveCause = kGiCauseNoObjects;
    else if (gi_.technique == gi::Technique::None || s.technique->technique() == gi::Technique::None)
        out.giInactiveCause = kGiCauseNoTechnique;
    else if (!s.valsUsable)
        out.giInactiveCause = kGiCauseUnregistered;
    else if (!w.frame.hasDepth())
        out.giInactiveCause = kGiCauseNoDepth;
    else
        out.giInactiveCause = kGiCauseNoVals;
}

// The GI ahead, first half: the next frame's VALs and their cull into the other generator, before this
// frame queues GL work (the cull's read-back then waits for its own pass only). Nothing of this frame after
// here uses the technique's VPLs once its GI is shaded (the vpl overlay does: no GI ahead with it).
void FramePipeline::makeNextFrameVals(FrameWork& w, NextFrame* next) {
    State& s = *state_;
    GiAhead& ahead = s.giAhead;
    // Deforming objects: the next frame deforms the meshes the job would read (applyContentAt drops it first), so
    // their GI runs in the frame.
    if (!(ahead.on && next != nullptr && w.runGi && w.cpuTechnique && w.valsOnCpu && s.vals &&
          options_.overlay != Overlay::VertexVpls && !renderer_->hasDeformingObjects()))
        return;
    const RgbdFrame* nextFrame = nullptr;
    const PreparedFrame* nextPrepared = nullptr;
    if (!next->wait(nextFrame, nextPrepared) || !nextPrepared->haveDepth || !nextPrepared->tracking.world_T_camera)
        return;
    const Pose& pose = *nextPrepared->tracking.world_T_camera;
    const cv::Mat& depth = nextPrepared->depthMetres;
    const auto valsStart = Clock::now();
    ahead.sequence = nextPrepared->sequence;
    ahead.generation = s.generation;
    ahead.instanceSetVersion = s.instanceSetVersion;
    const std::span<const gi::MeshInstance> instances = placeForNextFrame(*nextFrame, nextPrepared->sequence);
    try {
        const gi::CpuValGenerator& generator =
            generateCpuVals(nextPrepared->sequence, *nextFrame, depth, pose, instances, w.cpuTechnique->threads());
        GiJob& job = ahead.next;
        job.technique = w.cpuTechnique;
        job.vals = generator.lastVals();
        job.instances = instances;
        job.cameraPositionWorld = glm::vec3(pose.translation()); // as renderGBuffer's view
        job.pixels = {};
        if (!job.vals.empty())
            job.pixels = {generator.lastPixelIndices(), std::uint32_t(generator.depthWidth()),
                          std::uint32_t(generator.depthHeight())};
        job.realDepth = {};
        if (depth.isContinuous()) // as the GI stage's view.realDepth
            job.realDepth = realDepthView(depth, nextFrame->colourIntrinsics, pose, 0u);
        ahead.stage = GiAhead::Stage::ValsReady;
    } catch (...) {
        ahead.valsError = std::current_exception(); // the next frame's: its render() throws it
        ahead.stage = GiAhead::Stage::ValsFailed;
    }
    ahead.valsMs = msSince(valsStart);
}

// G-buffer and indirect light; then the GI ahead's second half: the next frame's stages 0-4 on the worker
// from now on (its VPLs replace this frame's in the technique, uploaded here), while this frame shades,
// reads back and composites.
void FramePipeline::renderGi(FrameWork& w) {
    State& s = *state_;
    render::Renderer& r = *renderer_;
    const auto t = Clock::now();
    if (!w.gbufferReady) r.renderGBuffer(*w.world_T_camera);
    if (w.runGi) {
        // The filtered registered depth for LightSkin's buried sparse points (guard G11); the other
        // techniques ignore it. On the GPU where the VAL pass uploaded it, always on the CPU.
        gi::ViewParameters view = r.viewParameters();
        if (w.prepared.haveDepth && w.prepared.depthMetres.isContinuous())
            view.realDepth = realDepthView(w.prepared.depthMetres, w.frame.colourIntrinsics, *w.world_T_camera,
                                           w.depthOnGpu ? s.vals->depthTexture() : 0u);
        if (w.cpuTechnique && w.valSet.buffer == 0)
            renderGiFromCpuVals(w, view);
        else
            s.technique->render(w.valSet, r.instances(), r.gbuffer(), view, r.indirectTarget());
        const gi::TechniqueFrameStatistics statistics = s.technique->lastFrameStatistics();
        if (statistics.reused >= 0) {
            w.out.giReused = statistics.reused;
            w.out.giChangeMeasure = statistics.changeMeasure;
        }
        if (statistics.voxelsDropped >= 0) w.out.volumeVoxelsDropped = statistics.voxelsDropped;
    }
    if (s.giAhead.stage == GiAhead::Stage::ValsReady) {
        s.technique->lastStageTimes(s.scratchTimes); // this frame's, before the worker replaces them
        w.stageTimesTaken = true;
        s.giAhead.launch();
    }
    addTime(w.out.cpuTimes, w.usedTimes, "gbuffer+gi", msSince(t)); // with the GI ahead: the wait for the worker
}

// The GI of a technique with CPU VALs: shade what the worker computed ahead, or compute and shade now.
void FramePipeline::renderGiFromCpuVals(FrameWork& w, const gi::ViewParameters& view) {
    State& s = *state_;
    render::Renderer& r = *renderer_;
    // the depth pixels of this frame's CPU VALs: the gather with a cut builds their quadtree
    gi::CpuValPixelKeys pixels;
    if (w.frameVals && !s.cpuValSet.empty())
        pixels = {w.frameVals->lastPixelIndices(), std::uint32_t(w.frameVals->depthWidth()),
                  std::uint32_t(w.frameVals->depthHeight())};
    if (w.useAhead) {
        s.giAhead.waitIdle(); // for the worker to finish this frame's stages 0-4
        if (s.giAhead.jobError) std::rethrow_exception(std::exchange(s.giAhead.jobError, nullptr));
        w.cpuTechnique->shadeVpls(r.instances(), r.gbuffer(), view, r.indirectTarget());
    } else
        w.cpuTechnique->renderCpuVals(s.cpuValSet, r.instances(), r.gbuffer(), view, r.indirectTarget(), pixels);
}

// Shade, read back, composite (and the linear composite with its NaN/inf counts).
void FramePipeline::composite(FrameWork& w) {
    State& s = *state_;
    render::Renderer& r = *renderer_;
    FrameOutput& out = w.out;
    w.compositeStart = Clock::now();
    w.realDepth = w.prepared.haveDepth ? w.prepared.depthMetres : cv::Mat();
    w.shade = render::ShadeOptions{.includeIndirect = w.runGi,
                                   .exposureStops = s.scene.exposureStops,
                                   .view = options_.view,
                                   .linearOutput = options_.linearComposite};
    r.shade(w.shade);
    r.readOutputsInto(s.virtualColour, s.virtualDepth);
    cv::extractChannel(s.virtualColour, s.coverage, 3);
    out.coveredPixels = cv::countNonZero(s.coverage);
    s.compositor.compositeInto(*w.camera, s.virtualColour, s.virtualDepth, w.realDepth, out.withGi);
    if (options_.differentialBaseline) {
        if (w.runDifferential)
            s.compositor.compositeInto(w.frame.colour, s.virtualColour, s.virtualDepth, w.realDepth,
                                       out.withGiWithoutDifferential);
        else
            out.withGi.copyTo(out.withGiWithoutDifferential);
    }
    if (options_.linearComposite) {
        r.readLinearOutputInto(s.virtualLinear);
        s.compositor.compositeLinearInto(*w.camera, s.virtualLinear, s.virtualColour, s.virtualDepth, w.realDepth,
                                         out.linearWithGi);
    }
    for (int v = 0; v < (options_.linearComposite ? out.linearWithGi.rows : 0); ++v) {
        const auto* row = out.linearWithGi.ptr<cv::Vec3f>(v);
        for (int u = 0; u < out.linearWithGi.cols; ++u) { // without branches: the compiler vectorises it
            const cv::Vec3f& p = row[u];
            const bool nan = std::isnan(p[0]) | std::isnan(p[1]) | std::isnan(p[2]);
            const bool inf = std::isinf(p[0]) | std::isinf(p[1]) | std::isinf(p[2]);
            out.linearNanPixels += nan ? 1 : 0;
            out.linearInfPixels += !nan && inf ? 1 : 0;
        }
    }
    if ((options_.linearIndirect || options_.referenceIndirect) && w.runGi) {
        r.readIndirectInto(s.indirectTechnique);
        cv::cvtColor(s.indirectTechnique, out.linearIndirect, cv::COLOR_RGBA2BGR);
        out.linearIndirect.convertTo(out.linearIndirect, -1, double(std::exp2(s.scene.exposureStops)));
    }
}

// The brute force beside the technique on the same VALs and G-buffer (options.referenceIndirect), with the
// coverage, normals and facing of the frame's virtual pixels.
void FramePipeline::renderReferenceIndirect(FrameWork& w) {
    if (!options_.referenceIndirect) return;
    State& s = *state_;
    render::Renderer& r = *renderer_;
    FrameOutput& out = w.out;
    // Coverage from the shaded output's alpha (the G-buffer's coverage), not from the light:
    // a covered pixel with no indirect light must still count.
    out.coverage.create(s.virtualColour.size(), CV_8UC1);
    cv::extractChannel(s.virtualColour, out.coverage, 3);
    cv::threshold(out.coverage, out.coverage, 0, 255, cv::THRESH_BINARY);
    s.compositor.visibleInto(s.virtualColour, s.virtualDepth, w.realDepth, out.visibleCoverage);
    s.virtualDepth.copyTo(out.virtualDepthMetres);
    const gi::GBufferView& g = r.gbuffer();
    gl::readTextureRgba32fInto(g.worldNormal, g.width, g.height, s.normalsRgba);
    cv::cvtColor(s.normalsRgba, out.virtualNormals, cv::COLOR_RGBA2RGB);
    cv::extractChannel(s.normalsRgba, s.facing, 3); // w = 1 on back faces, 0 on front faces and background
    cv::compare(s.facing, 0.5, out.backFacing, cv::CMP_GT);
    if (!w.runGi) return;
    renderBruteForce(w);
    cv::cvtColor(s.indirectReference, out.linearIndirectReference, cv::COLOR_RGBA2BGR);
    out.linearIndirectReference.convertTo(out.linearIndirectReference, -1, double(std::exp2(s.scene.exposureStops)));
}

// The brute force into the renderer's indirect target, read back into State::indirectReference.
void FramePipeline::renderBruteForce(FrameWork& w) {
    State& s = *state_;
    render::Renderer& r = *renderer_;
    if (!s.bruteForce) {
        s.bruteForce = bruteForceFor(gi_, r);
        s.bruteForce->prepare(r.instances());
    }
    s.bruteForce->render(w.valSet, r.instances(), r.gbuffer(), r.viewParameters(), r.indirectTarget());
    r.readIndirectInto(s.indirectReference);
}

void FramePipeline::drawOverlays(FrameWork& w) {
    State& s = *state_;
    FrameOutput& out = w.out;
    const CameraIntrinsics& k = w.frame.colourIntrinsics;
    if (options_.overlay == Overlay::Vals && out.valCount > 0 && s.vals)
        drawVals(out.withGi, s.vals->downloadVals(), k, *w.world_T_camera);
    if (options_.overlay == Overlay::Differential && w.runDifferential)
        drawDifferential(out.withGi, w.frame.colour, s.differentialImages);
    if (options_.overlay == Overlay::SparsePoints) drawSparsePoints(out.withGi, *renderer_, k, *w.world_T_camera);
    if (options_.overlay == Overlay::VertexVpls && w.runGi && s.technique->capabilities().vertexVpls) {
        const VplViewResult vpl =
            drawVertexVpls(out.withGi, *s.technique, renderer_->instances(), k, *w.world_T_camera, s.vertexVpls);
        out.vplSegments = vpl.drawn;
        out.vplNonFinite = vpl.nonFinite;
    }
    if (options_.overlay == Overlay::ErrorVsBruteForce && w.runGi) drawErrorVsBruteForce(w);
    if (options_.overlay == Overlay::LightEstimate && out.lightEstimate)
        drawLightEstimateInto(out.withGi, *out.lightEstimate, k, *w.world_T_camera);
}

// Luminance of |technique - brute force| mapped to a colour ramp over covered pixels; the mean relative
// error in text.
void FramePipeline::drawErrorVsBruteForce(FrameWork& w) {
    State& s = *state_;
    FrameOutput& out = w.out;
    renderer_->readIndirectInto(s.indirectTechnique);
    renderBruteForce(w);
    s.errorMap.create(s.indirectTechnique.size(), CV_8UC3);
    double sumError = 0.0, sumReference = 0.0;
    for (int v = 0; v < s.errorMap.rows; ++v)
        for (int u = 0; u < s.errorMap.cols; ++u) {
            const cv::Vec4f a = s.indirectTechnique.at<cv::Vec4f>(v, u), b = s.indirectReference.at<cv::Vec4f>(v, u);
            const float la = 0.2126f * a[0] + 0.7152f * a[1] + 0.0722f * a[2];
            const float lb = 0.2126f * b[0] + 0.7152f * b[1] + 0.0722f * b[2];
            if (s.virtualColour.at<cv::Vec4b>(v, u)[3] == 0) continue;
            sumError += std::abs(double(la) - double(lb));
            sumReference += std::abs(double(lb));
            const float level = std::clamp(std::abs(la - lb) / options_.errorScale, 0.0f, 1.0f);
            out.withGi.at<cv::Vec3b>(v, u) =
                cv::Vec3b(std::uint8_t(255.0f * (1.0f - level)), 0, std::uint8_t(255.0f * level));
        }
    out.meanRelativeErrorVsBruteForce = sumReference > 0.0 ? sumError / sumReference : 0.0;
    char text[96];
    std::snprintf(text, sizeof text, "|%s - brute force| / brute force: %.3f", std::string(s.technique->name()).c_str(),
                  out.meanRelativeErrorVsBruteForce);
    cv::putText(out.withGi, text, cv::Point(6, 16), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(255, 255, 255), 1,
                cv::LINE_AA);
}

// The figure-4 comparison: the same frame without indirect light, over the plain camera image.
void FramePipeline::compositeWithoutGi(FrameWork& w) {
    State& s = *state_;
    w.shade.includeIndirect = false;
    w.shade.linearOutput = false;
    if (w.shade.view == render::DebugView::IndirectOnly) w.shade.view = render::DebugView::Final;
    renderer_->shade(w.shade);
    renderer_->readOutputsInto(s.virtualColour, s.virtualDepth);
    s.compositor.compositeInto(w.frame.colour, s.virtualColour, s.virtualDepth, w.realDepth, w.out.withoutGi);
}

// The technique's stage times: those it measures on the CPU into the frame's CPU times under their labels,
// the others (GL timers) into its GPU times, after the renderer's and the RSM's.
void FramePipeline::collectStageTimes(FrameWork& w) {
    State& s = *state_;
    FrameOutput& out = w.out;
    const std::span<const gi::CpuStageLabel> cpuStages = s.technique->capabilities().cpuStages;
    if (w.runGi && !cpuStages.empty()) {
        if (!w.stageTimesTaken) s.technique->lastStageTimes(s.scratchTimes);
        for (const gi::CpuStageLabel& stage : cpuStages)
            for (const gl::StageTime& st : s.scratchTimes)
                if (st.name == stage.stage) addTime(out.cpuTimes, w.usedTimes, stage.label, st.milliseconds);
    }
    out.cpuTimes.resize(w.usedTimes);
    renderer_->lastStageTimes(out.gpuTimes);
    if (w.rsmTimed) {
        s.rsmTimer.collect(s.rsmTimes);
        out.gpuTimes.insert(out.gpuTimes.end(), s.rsmTimes.begin(), s.rsmTimes.end());
    }
    if (!w.runGi) return;
    if (!w.stageTimesTaken) s.technique->lastStageTimes(s.scratchTimes);
    for (const gl::StageTime& st : s.scratchTimes) {
        bool onCpu = false;
        for (const gi::CpuStageLabel& stage : cpuStages) onCpu = onCpu || st.name == stage.stage;
        if (!onCpu) out.gpuTimes.push_back(st);
    }
}

} // namespace lightskin::mr
