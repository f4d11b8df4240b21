// lightskin_bench_motion: temporal coherence of LightSkin under motion, the way the paper claims it ("animations
// must not introduce undesirable flickering"). A separate program, never a test; the numbers go to
// docs/BENCHMARKS.md "Flicker under motion" with this command:
//   build/bench/lightskin_bench_motion [recording=recordings/synth-orbit] [scene ...]
// default scenes: recordings/scenes/orbit_slide.json (the cube rests, slides and turns across the table, rests),
// orbit_light_moving.json (a virtual light circles the objects; its bounce reaches them as RSM VALs) and
// orbit_skinned.json (a skinned cylinder bends). Every frame runs through the production pipeline
// (mr::FramePipeline, ground-truth poses, the default backend) with the brute force on the same VALs beside
// LightSkin (PipelineOptions::referenceIndirect). Tracked points are every k-th vertex of every object (~1500 per
// mesh) in object space: they move and deform with their object. Printed per scene: flicker of both techniques
// and LightSkin's excess (bench/Flicker.h), over all frames and over the frame pairs where content starts or stops
// moving (a pop would show there), and the largest excess of a single frame pair.
#include <lightskin/bench/Flicker.h>
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/gi/reference/RayTracedGroundTruth.h>
#include <lightskin/gl/Context.h>
#include <lightskin/gl/Readback.h>
#include <lightskin/mr/FramePipeline.h>
#include <lightskin/render/Scene.h>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vector_relational.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace {

using namespace lightskin;

/// Every k-th vertex of every object, world space, in a fixed order (k keeps ~1500 per mesh).
void trackedPointsInto(std::span<const gi::MeshInstance> instances, std::vector<glm::dvec3>& points) {
    points.clear();
    for (const gi::MeshInstance& m : instances) {
        const std::size_t step = std::max<std::size_t>(1, m.mesh->vertexCount() / 1500);
        for (std::size_t i = 0; i < m.mesh->vertexCount(); i += step)
            points.emplace_back(m.world_T_model * glm::vec4(m.mesh->positions[i], 1.0f));
    }
}

/// Whether the objects' placement changed between the two frames' point sets (moved or deformed by > 0.1 mm).
bool moved(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b) {
    if (a.size() != b.size()) return true;
    for (std::size_t i = 0; i < a.size(); ++i)
        if (glm::length(a[i] - b[i]) > 1e-4) return true;
    return false;
}

/// LightSkin's and the brute force's indirect light against the Embree truth (with visibility between the objects,
/// the same depth VALs) at up to kTruthPixels covered pixels of one frame: relative RMS errors, sqrt(sum (x - t)^2 /
/// sum t^2) over the pixels and channels.
struct TruthError {
    double lightSkin = 0.0, bruteForce = 0.0;
    std::size_t pixels = 0;
};
constexpr std::size_t kTruthPixels = 256;

/// An object's world bounding box, grown by 1 mm.
struct ObjectBox {
    const gi::MeshInstance* instance;
    glm::vec3 lo{std::numeric_limits<float>::max()}, hi{-std::numeric_limits<float>::max()};
};

std::vector<ObjectBox> objectBoxes(std::span<const gi::MeshInstance> instances) {
    std::vector<ObjectBox> boxes;
    for (const gi::MeshInstance& m : instances) {
        ObjectBox box{&m};
        for (const glm::vec3& v : m.mesh->positions) {
            const glm::vec3 w(m.world_T_model * glm::vec4(v, 1.0f));
            box.lo = glm::min(box.lo, w - 1e-3f);
            box.hi = glm::max(box.hi, w + 1e-3f);
        }
        boxes.push_back(box);
    }
    return boxes;
}

/// The object whose box holds `p` (the first), or nullptr.
const gi::MeshInstance* objectAt(const std::vector<ObjectBox>& boxes, const glm::vec3& p) {
    for (const ObjectBox& box : boxes)
        if (glm::all(glm::greaterThanEqual(p, box.lo)) && glm::all(glm::lessThanEqual(p, box.hi))) return box.instance;
    return nullptr;
}

TruthError truthError(mr::FramePipeline& pipeline, const mr::FrameOutput& out, double exposureScale) {
    std::vector<gi::VirtualAreaLight> vals;
    std::vector<std::uint32_t> valPixels;
    pipeline.downloadDepthValsInto(vals, valPixels);
    const gi::GBufferView& g = pipeline.renderer().gbuffer();
    cv::Mat positions;
    gl::readTextureRgba32fInto(g.worldPosition, g.width, g.height, positions);
    const auto instances = pipeline.renderer().instances();
    const std::vector<ObjectBox> boxes = objectBoxes(instances);
    std::vector<cv::Point> covered;
    for (int v = 0; v < positions.rows; ++v)
        for (int u = 0; u < positions.cols; ++u)
            if (out.visibleCoverage.at<std::uint8_t>(v, u) && positions.at<cv::Vec4f>(v, u)[3] > 0.0f)
                covered.emplace_back(u, v);
    std::vector<cv::Point> chosen;
    std::vector<gi::GroundTruthReceiver> receivers;
    const glm::dvec3 eye = out.world_T_camera->translation();
    for (std::size_t i = 0; i < std::min(kTruthPixels, covered.size()); ++i) {
        const cv::Point px = covered[i * covered.size() / std::min(kTruthPixels, covered.size())];
        const cv::Vec4f p = positions.at<cv::Vec4f>(px.y, px.x);
        const gi::MeshInstance* owner = objectAt(boxes, {p[0], p[1], p[2]});
        if (owner == nullptr) continue;
        const cv::Vec3f n = out.virtualNormals.at<cv::Vec3f>(px.y, px.x);
        gi::GroundTruthReceiver r;
        r.position = glm::dvec3(p[0], p[1], p[2]);
        r.normal = glm::normalize(glm::dvec3(n[0], n[1], n[2]));
        r.toViewer = glm::normalize(eye - r.position);
        r.material = owner->material;
        receivers.push_back(r);
        chosen.push_back(px);
    }
    std::vector<gi::GroundTruthMesh> meshes;
    for (const gi::MeshInstance& m : instances) meshes.push_back({m.mesh, glm::dmat4(m.world_T_model)});
    std::vector<gi::GroundTruthResult> results(receivers.size());
    gi::RayTracedGroundTruth::create(meshes).compute(vals, receivers, results, gi::GroundTruthSettings{});
    double ls = 0.0, bf = 0.0, signal = 0.0;
    for (std::size_t i = 0; i < chosen.size(); ++i) {
        const cv::Vec3f a = out.linearIndirect.at<cv::Vec3f>(chosen[i]);
        const cv::Vec3f b = out.linearIndirectReference.at<cv::Vec3f>(chosen[i]);
        const glm::dvec3 t = exposureScale * results[i].radiance;
        for (int c = 0; c < 3; ++c) { // BGR images, RGB truth
            const double truth = t[2 - c];
            ls += (double(a[c]) - truth) * (double(a[c]) - truth);
            bf += (double(b[c]) - truth) * (double(b[c]) - truth);
            signal += truth * truth;
        }
    }
    TruthError e;
    e.pixels = chosen.size();
    if (signal > 0.0) {
        e.lightSkin = std::sqrt(ls / signal);
        e.bruteForce = std::sqrt(bf / signal);
    }
    return e;
}

struct SceneResult {
    bench::FlickerSeries::Result all, transitions;
    double worstPairExcess = 0.0, excessWithout5Percent = 0.0;
    std::vector<TruthError> truth; // at the first, middle and last frame; none with RSM VALs (not in the truth)
    int worstPair = -1, frames = 0, transitionPairs = 0;
    std::string backend;
};

SceneResult measure(const std::string& recording, const std::string& scenePath) {
    const render::Scene scene = render::loadScene(scenePath);
    auto source = capture::openFrameSource(recording);
    mr::PipelineOptions options;
    options.poseMode = mr::PoseMode::GroundTruth;
    options.compare = false;
    options.view = render::DebugView::IndirectOnly;
    options.referenceIndirect = true;
    auto pipeline = mr::FramePipeline::create(scene, source->info(), options);
    SceneResult r;
    r.backend = pipeline->techniqueName();
    std::vector<glm::dvec3> points, previous;
    std::vector<bool> moving; // per frame pair (f - 1, f): did content move between them
    std::optional<bench::FlickerSeries> series;
    const int frames = int(source->frameCount().value_or(0));
    RgbdFrame frame;
    mr::FrameOutput out;
    while (source->next(frame)) {
        pipeline->process(frame, out);
        if (!out.world_T_camera || out.linearIndirect.empty() || out.linearIndirectReference.empty())
            throw Error(recording, frame.index, "no pose or no GI in this frame");
        trackedPointsInto(pipeline->renderer().instances(), points);
        if (!series) series.emplace(points.size());
        if (r.frames > 0) moving.push_back(moved(previous, points));
        series->addFrame(points, frame.colourIntrinsics, *out.world_T_camera, out.coverage, out.virtualDepthMetres,
                         out.linearIndirect, out.linearIndirectReference);
        previous.swap(points);
        if (!scene.gi.virtualBounce && (r.frames == 0 || r.frames == frames / 2 || r.frames == frames - 1))
            r.truth.push_back(truthError(*pipeline, out, std::exp2(double(scene.exposureStops))));
        ++r.frames;
    }
    r.all = series->measure();
    r.excessWithout5Percent = series->excessWithoutWorst(0.05);
    // Pops: the pairs where motion starts or stops (moving differs from the pair before).
    double transitionSquares = 0.0;
    std::size_t transitionSamples = 0;
    for (int f = 1; f < r.frames; ++f) {
        const bench::FlickerSeries::Result pair = series->measure(f, f + 1);
        if (pair.samples > 0 && pair.excess > r.worstPairExcess) {
            r.worstPairExcess = pair.excess;
            r.worstPair = f;
        }
        const bool transition = f >= 2 && moving[std::size_t(f - 1)] != moving[std::size_t(f - 2)];
        if (transition && pair.samples > 0) {
            ++r.transitionPairs;
            transitionSquares += pair.excess * pair.excess * double(pair.samples);
            transitionSamples += pair.samples;
        }
    }
    if (transitionSamples > 0) {
        r.transitions.samples = transitionSamples;
        r.transitions.excess = std::sqrt(transitionSquares / double(transitionSamples));
    }
    return r;
}

} // namespace

int main(int argc, char** argv) try {
    const std::string recording = argc > 1 ? argv[1] : "recordings/synth-orbit";
    std::vector<std::string> scenes;
    for (int i = 2; i < argc; ++i) scenes.emplace_back(argv[i]);
    if (scenes.empty())
        scenes = {"recordings/scenes/orbit_slide.json", "recordings/scenes/orbit_light_moving.json",
                  "recordings/scenes/orbit_skinned.json"};
    auto context = gl::createHeadlessContext();
    std::printf("| scene | LightSkin backend | frames | samples | flicker brute force | flicker LightSkin | excess "
                "LightSkin | without the 5 %% worst points | excess at motion start/stop (pairs) | worst pair's excess "
                "(frame) |\n"
                "|---|---|---|---|---|---|---|---|---|---|\n");
    for (const std::string& scene : scenes) {
        const SceneResult r = measure(recording, scene);
        std::string truth, truthBf;
        for (const TruthError& t : r.truth) {
            char text[64];
            std::snprintf(text, sizeof text, "%s%.3f", truth.empty() ? "" : " / ", t.lightSkin);
            truth += text;
            std::snprintf(text, sizeof text, "%s%.3f", truthBf.empty() ? "" : " / ", t.bruteForce);
            truthBf += text;
        }
        std::printf("| %s | %s | %d | %zu | %.4f | %.4f | %.4f | %.4f | %.4f (%d) | %.4f (%d) | %s |\n", scene.c_str(),
                    r.backend.c_str(), r.frames, r.all.samples, r.all.bruteForce, r.all.lightSkin, r.all.excess,
                    r.excessWithout5Percent, r.transitions.excess, r.transitionPairs, r.worstPairExcess, r.worstPair,
                    r.truth.empty() ? "n/a (RSM VALs)" : (truth + "; " + truthBf).c_str());
        std::fflush(stdout);
    }
    return 0;
} catch (const std::exception& error) {
    std::fprintf(stderr, "lightskin_bench_motion: %s\n", error.what());
    return 1;
}
