// `lightskin bench-realdepth`: the indirect light of virtual objects standing on real surfaces of the
// bundled real RGB-D recordings. For every recording the bunny and the cube of
// recordings/scenes/on_real_surface.json are placed on the plane fitted to the depth around an anchor
// pixel of frame 0 (resting on it, or sunk into it by --sink), and every frame runs through the
// production per-frame pipeline (mr::FramePipeline: bilateral filter, VALs, G-buffer, GI). Per light
// model (the old one and the robust one, see render::GiSettings) and frame it measures, for LightSkin
// and for the brute force on the same VALs:
//   * speckle (eval::measureSpeckle) with its black and blown pixels,
//   * the total indirect light (sum of luminance over covered pixels), to report the change against
//     the old model,
//   * flicker on sequences whose poses hold (ground truth, or the .oni's camera at rest), defined as
//     `lightskin bench`'s: RMS over tracked surface points (every k-th mesh vertex, visible in both frames) and
//     consecutive frame pairs of the change of the indirect light (mean of the channels), divided by the brute force's
//     mean level; "excess" subtracts the brute force's own change per sample.
// A benchmark, not a test: prints Markdown tables (and writes them with PNGs of the indirect light to
// --out). tests/apps/RealDepthDataGLTest.cpp asserts the targets on every recording (exceptions named there).

#include <lightskin/bench/BenchReport.h>
#include <lightskin/bench/Flicker.h>
#include <lightskin/bench/RealDepthBench.h>
#include <lightskin/bench/StopRequest.h>
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/eval/ColourSpace.h>
#include <lightskin/eval/Speckle.h>
#include <lightskin/gi/common/Technique.h>
#include <lightskin/gi/reference/IrradianceSensitivity.h>
#include <lightskin/gi/reference/RayTracedGroundTruth.h>
#include <lightskin/gl/Context.h>
#include <lightskin/gl/DebugOutput.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/gl/Readback.h>
#include <lightskin/mr/FramePipeline.h>
#include <lightskin/render/Scene.h>
#include <lightskin/tracking/PoseTracker.h>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

namespace lightskin::bench {

namespace {

struct Anchor {
    int u = 0, v = 0; ///< pixel of frame 0 on the real surface the object stands on
};

struct RealCase {
    std::string name;
    std::string recording; ///< relative to --data (tests/data)
    mr::PoseMode pose;
    Anchor bunny, cube;
    bool flicker; ///< a sequence with poses that hold (ground truth, or a camera at rest): flicker is meaningful
    /// Plane fit: window points within this depth of the anchor's (metres). 3 cm keeps neighbouring
    /// objects out; a floor seen at a grazing angle changes depth by ~2 cm per pixel row at 2 m.
    double fitDepthWindow = 0.03;
    int frames = 5; ///< frames measured (fewer with --max-frames)
};

/// The bundled registered real recordings. Anchors: free table or floor next to other real objects
/// (chosen by looking at frame 0; the objects' bases must be fully on one surface).
std::vector<RealCase> realCases() {
    return {
        {"tum-fr2-desk", "tum-fr2-desk", mr::PoseMode::Fixed, {300, 365}, {150, 335}, false},
        {"icl-nuim", "icl-nuim-open3d", mr::PoseMode::GroundTruth, {250, 390}, {460, 430}, true},
        {"pcl-kinect-tiff", "pcl-kinect-tiff", mr::PoseMode::Fixed, {250, 380}, {520, 380}, false},
        // fr3/long_office_household (one frame): the bunny on the floor between the two chairs, the
        // cube on the floor right of the yellow chair (~2 m from the camera)
        {"tum-fr3-office", "tum-fr3-office", mr::PoseMode::Fixed, {300, 440}, {580, 420}, false},
        // The real Kinect v1 .oni (12 frames, camera at rest, depth registered in software): both objects
        // on the living-room floor ~2.2 m away, in front of the office chair (recordings/scenes/oni_room.json's
        // floor patch). A camera at rest still flickers: the VALs follow the depth noise frame to frame.
        {"oni-kinect-v1", "oni-kinect-v1/3dj_test.oni", mr::PoseMode::Fixed, {330, 440}, {250, 445}, true, 0.15, 12},
    };
}

/// The light models compared. "old": the guards for real depth off (render::GiSettings::robustRealDepth off);
/// "robust": the fixes on (the default).
struct LightModel {
    std::string name;
    bool robust;
    bool irradianceCap = true;      ///< with robust: guard G10 (false: "robust-nocap")
    bool buriedSparsePoints = true; ///< with robust: guard G11 (false: "robust-noburied")
    bool nearField = false;         ///< with robust: guard G12, near-field VALs as areas ("robust-area")
};

struct Bounds {
    glm::vec3 lo{std::numeric_limits<float>::max()}, hi{-std::numeric_limits<float>::max()};
};

/// Model-space bounds of an ASCII PLY or OBJ mesh's vertices (the two template meshes).
Bounds meshBounds(const std::filesystem::path& path) {
    std::ifstream in(path);
    if (!in) throw Error(path.string(), std::nullopt, "cannot read");
    Bounds b;
    std::string line;
    const auto add = [&b](float x, float y, float z) {
        b.lo = glm::min(b.lo, glm::vec3(x, y, z));
        b.hi = glm::max(b.hi, glm::vec3(x, y, z));
    };
    if (path.extension() == ".ply") {
        long vertices = -1;
        while (std::getline(in, line) && line != "end_header")
            if (line.rfind("element vertex ", 0) == 0) vertices = std::stol(line.substr(15));
        for (long i = 0; i < vertices && std::getline(in, line); ++i) {
            std::istringstream s(line);
            float x = 0, y = 0, z = 0;
            s >> x >> y >> z;
            add(x, y, z);
        }
    } else {
        while (std::getline(in, line))
            if (line.rfind("v ", 0) == 0) {
                std::istringstream s(line.substr(2));
                float x = 0, y = 0, z = 0;
                s >> x >> y >> z;
                add(x, y, z);
            }
    }
    if (!(b.lo.x <= b.hi.x)) throw Error(path.string(), std::nullopt, "no vertices");
    return b;
}

struct SurfacePoint {
    glm::dvec3 position; ///< camera frame, metres
    glm::dvec3 normal;   ///< camera frame, unit, facing the camera
};

/// Plane through the depth around pixel (u, v) of frame 0: points of a 31x31 window within depthWindow
/// of the anchor's depth, normal = the smallest principal axis (cv::PCA), facing the camera.
SurfacePoint fitSurface(const RgbdFrame& frame, const Anchor& a, double depthWindow, const std::string& name) {
    const CameraIntrinsics& k = frame.depthIntrinsics;
    const auto depthAt = [&](int u, int v) {
        return frame.depth.type() == CV_16UC1 ? double(frame.depth.at<std::uint16_t>(v, u)) * frame.depthScaleMetres
                                              : double(frame.depth.at<float>(v, u));
    };
    // The anchor's depth: the median of the valid depth in its 5x5 window (software-registered depth
    // has single-pixel holes where depth pixels did not land).
    std::vector<double> near;
    for (int v = a.v - 2; v <= a.v + 2; ++v)
        for (int u = a.u - 2; u <= a.u + 2; ++u)
            if (u >= 0 && v >= 0 && u < frame.depth.cols && v < frame.depth.rows && depthAt(u, v) > 0.0)
                near.push_back(depthAt(u, v));
    if (near.size() < 5) throw Error(name, 0, "the anchor pixel's 5x5 window has almost no depth");
    std::nth_element(near.begin(), near.begin() + std::ptrdiff_t(near.size() / 2), near.end());
    // The anchor pixel's own depth where it has one (the placements of the earlier tables and of
    // tests/apps/RealDepthDataGLTest.cpp), else the median of its window.
    const double z0 = depthAt(a.u, a.v) > 0.0 ? depthAt(a.u, a.v) : near[near.size() / 2];
    std::vector<cv::Vec3d> points;
    for (int v = a.v - 15; v <= a.v + 15; ++v)
        for (int u = a.u - 15; u <= a.u + 15; ++u) {
            if (u < 0 || v < 0 || u >= frame.depth.cols || v >= frame.depth.rows) continue;
            const double z = depthAt(u, v);
            if (z > 0.0 && std::abs(z - z0) < depthWindow) {
                const glm::dvec3 p = k.backProject(u, v, z);
                points.emplace_back(p.x, p.y, p.z);
            }
        }
    if (points.size() < 100) throw Error(name, 0, "too few depth points around the anchor");
    cv::Mat data(int(points.size()), 3, CV_64F, points.data());
    const cv::PCA pca(data, cv::noArray(), cv::PCA::DATA_AS_ROW);
    SurfacePoint s;
    s.position = k.backProject(a.u, a.v, z0);
    s.normal = glm::normalize(glm::dvec3(pca.eigenvectors.at<double>(2, 0), pca.eigenvectors.at<double>(2, 1),
                                         pca.eigenvectors.at<double>(2, 2)));
    if (glm::dot(s.normal, s.position) > 0.0) s.normal = -s.normal;
    // Move the base point onto the fitted plane (the anchor pixel's own depth is noisy).
    const glm::dvec3 mean(pca.mean.at<double>(0), pca.mean.at<double>(1), pca.mean.at<double>(2));
    s.position -= glm::dot(s.position - mean, s.normal) * s.normal;
    return s;
}

/// world_T_model placing the model's base (min y, centred in x and z) on the surface, model +y along
/// its normal, sunk by `sink` metres.
glm::mat4 placeOnSurface(const Bounds& b, float scale, const glm::dvec3& pointWorld, const glm::dvec3& normalWorld,
                         double sink) {
    const glm::vec3 base(0.5f * (b.lo.x + b.hi.x), b.lo.y, 0.5f * (b.lo.z + b.hi.z));
    const glm::quat q(glm::vec3(0.0f, 1.0f, 0.0f), glm::vec3(normalWorld)); // shortest arc from +y to the normal
    const glm::vec3 p(pointWorld - sink * normalWorld);
    return glm::translate(glm::mat4(1.0f), p) * glm::mat4_cast(q) * glm::scale(glm::mat4(1.0f), glm::vec3(scale)) *
           glm::translate(glm::mat4(1.0f), -base);
}

/// Normals within this angle over a 5x5 window count as one smooth patch. The bunny (res4, 948
/// triangles, ~1 cm edges at 1.5x scale) turns its normal by ~10-20 degrees per edge on the body and
/// more on ears and feet; 30 degrees keeps the body and drops creases and occlusion edges.
constexpr double kSmoothAngleDegrees = 30.0;

struct TechniqueStats {
    eval::SpeckleStats speckle;       ///< summed over frames
    eval::SpeckleStats speckleMedian; ///< the median-only definition (before the smooth-profile test)
    /// The proposal for TUM fr3 (eval::smoothSurfaceMaskInto with the irradiance's normal sensitivity S):
    /// pixels whose normal is more than 0.5 / S radians from their window's mean normal are left out too.
    eval::SpeckleStats speckleSensitive;
    double totalLight = 0.0; ///< sum of luminance over covered pixels, all frames
};

struct CaseResult {
    std::string recording, model;
    int frames = 0;
    double sink = 0.0;
    std::uint64_t vals = 0;
    TechniqueStats lightSkin, brute;
    bool flickerMeasured = false;
    double flickerLightSkin = 0.0, flickerBrute = 0.0, excessFlicker = 0.0;
    std::size_t flickerSamples = 0;
};

void accumulate(eval::SpeckleStats& sum, const eval::SpeckleStats& s) {
    sum.meanLuminance = (sum.meanLuminance * double(sum.interiorPixels) + s.meanLuminance * double(s.interiorPixels)) /
                        double(std::max<std::size_t>(1, sum.interiorPixels + s.interiorPixels));
    sum.interiorPixels += s.interiorPixels;
    sum.specklePixels += s.specklePixels;
    sum.blackPixels += s.blackPixels;
    sum.blownPixels += s.blownPixels;
}

double coveredLuminance(const cv::Mat& linearBgr, const cv::Mat& coverage) {
    cv::Mat y;
    eval::luminanceInto(linearBgr, y);
    return cv::mean(y, coverage)[0] * double(cv::countNonZero(coverage));
}

/// The indirect image as an 8-bit sRGB PNG, scaled so that 4x the mean covered luminance is white.
void writeIndirectPng(const std::filesystem::path& path, const cv::Mat& linearBgr, double meanLuminance) {
    cv::Mat scaled, srgb;
    linearBgr.convertTo(scaled, CV_32FC3, meanLuminance > 0.0 ? 0.25 / meanLuminance : 1.0);
    eval::linearToSrgb8Into(scaled, srgb);
    cv::imwrite(path.string(), srgb);
}

/// --maps: the luminance of an indirect image as raw float32, rows top to bottom (for analysis scripts).
void writeRawLuminance(const std::filesystem::path& path, const cv::Mat& linearBgr) {
    cv::Mat y;
    eval::luminanceInto(linearBgr, y);
    std::ofstream file(path, std::ios::binary);
    for (int v = 0; v < y.rows; ++v)
        file.write(reinterpret_cast<const char*>(y.ptr<float>(v)), std::streamsize(sizeof(float)) * y.cols);
    if (!file) throw Error(path.string(), std::nullopt, "cannot write");
}

/// --maps: one CSV line per speckle pixel (either technique) with both techniques' luminance and the
/// 5x5 median, the G-buffer normal and depth, to find where speckle comes from.
void dumpSpecklePixels(std::ofstream& csv, const RgbdFrame& frame, const mr::FrameOutput& out, const cv::Mat& mapLs,
                       const cv::Mat& mapBf) {
    cv::Mat yLs, yBf, mLs, mBf;
    eval::luminanceInto(out.linearIndirect, yLs);
    eval::luminanceInto(out.linearIndirectReference, yBf);
    cv::Mat finiteLs = yLs.clone(), finiteBf = yBf.clone();
    cv::patchNaNs(finiteLs, 0.0);
    cv::patchNaNs(finiteBf, 0.0);
    cv::medianBlur(finiteLs, mLs, 5);
    cv::medianBlur(finiteBf, mBf, 5);
    for (int v = 0; v < mapLs.rows; ++v)
        for (int u = 0; u < mapLs.cols; ++u)
            for (const bool lightSkin : {true, false}) {
                if ((lightSkin ? mapLs : mapBf).at<std::uint8_t>(v, u) != 255) continue;
                const cv::Vec3f n = out.virtualNormals.at<cv::Vec3f>(v, u);
                const double real = frame.depth.type() == CV_16UC1
                                        ? double(frame.depth.at<std::uint16_t>(v, u)) * frame.depthScaleMetres
                                        : double(frame.depth.at<float>(v, u));
                const gi::Technique technique = lightSkin ? gi::Technique::LightSkin : gi::Technique::BruteForce;
                csv << frame.index << ',' << u << ',' << v << ',' << gi::toString(technique) << ','
                    << (lightSkin ? yLs : yBf).at<float>(v, u) << ',' << (lightSkin ? mLs : mBf).at<float>(v, u) << ','
                    << (lightSkin ? yBf : yLs).at<float>(v, u) << ',' << n[0] << ',' << n[1] << ',' << n[2] << ','
                    << out.virtualDepthMetres.at<float>(v, u) << ',' << real << ','
                    << (out.backFacing.at<std::uint8_t>(v, u) ? 1 : 0) << '\n';
            }
}

/// --maps (first frame of each case): the frame's depth VALs (as the techniques received them: culled ones have area 0)
/// as CSV, and the G-buffer's world positions and normals as raw float32 RGBA (rows top to bottom), so that an analysis
/// script can split a pixel's brute-force irradiance by VAL (eq. 3 and 4 per VAL).
void dumpValsAndGBuffer(const std::filesystem::path& stem, mr::FramePipeline& pipeline, int depthWidth) {
    std::vector<gi::VirtualAreaLight> vals;
    std::vector<std::uint32_t> pixels;
    pipeline.downloadDepthValsInto(vals, pixels);
    std::ofstream csv(stem.string() + "_vals.csv");
    csv << "u,v,x,y,z,normal_x,normal_y,normal_z,area,flux_r,flux_g,flux_b\n";
    for (std::size_t i = 0; i < vals.size() && i < pixels.size(); ++i) {
        const gi::VirtualAreaLight& l = vals[i];
        csv << pixels[i] % std::uint32_t(depthWidth) << ',' << pixels[i] / std::uint32_t(depthWidth) << ','
            << l.position.x << ',' << l.position.y << ',' << l.position.z << ',' << l.normal.x << ',' << l.normal.y
            << ',' << l.normal.z << ',' << l.area << ',' << l.flux.x << ',' << l.flux.y << ',' << l.flux.z << '\n';
    }
    if (!csv) throw Error(stem.string() + "_vals.csv", std::nullopt, "cannot write");
    const gi::GBufferView& g = pipeline.renderer().gbuffer();
    cv::Mat rgba;
    for (const auto& [texture, suffix] :
         {std::pair{g.worldPosition, "_gbuffer_position.f32"}, std::pair{g.worldNormal, "_gbuffer_normal.f32"}}) {
        gl::readTextureRgba32fInto(texture, g.width, g.height, rgba);
        std::ofstream file(stem.string() + suffix, std::ios::binary);
        file.write(reinterpret_cast<const char*>(rgba.data), std::streamsize(rgba.total() * rgba.elemSize()));
        if (!file) throw Error(stem.string() + suffix, std::nullopt, "cannot write");
    }
}

/// --maps: the 20 tracked points with the largest excess change (LightSkin's change minus the brute
/// force's, between consecutive frames), with both series, to find where flicker comes from.
void dumpWorstFlicker(const std::filesystem::path& folder, const std::string& name, double sink,
                      const std::vector<glm::dvec3>& points, int frames, const std::vector<float>& ls,
                      const std::vector<float>& bf) {
    std::vector<std::pair<double, std::size_t>> worst;
    for (std::size_t p = 0; p < points.size(); ++p) {
        double largest = 0.0;
        for (int f = 1; f < frames; ++f) {
            const std::size_t i0 = std::size_t(f - 1) * points.size() + p, i1 = i0 + points.size();
            const double d = (double(ls[i1]) - double(ls[i0])) - (double(bf[i1]) - double(bf[i0]));
            if (std::isfinite(d)) largest = std::max(largest, std::abs(d));
        }
        worst.emplace_back(largest, p);
    }
    std::sort(worst.rbegin(), worst.rend());
    char file[200];
    std::snprintf(file, sizeof file, "%s_sink%.0fmm_worst_flicker.csv", name.c_str(), sink * 1e3);
    std::ofstream csv(folder / file);
    csv << "point,x,y,z,largest_excess_change,frame,lightskin,bruteforce\n";
    for (std::size_t k = 0; k < std::min<std::size_t>(20, worst.size()); ++k) {
        const std::size_t p = worst[k].second;
        for (int f = 0; f < frames; ++f) {
            const std::size_t i = std::size_t(f) * points.size() + p;
            csv << p << ',' << points[p].x << ',' << points[p].y << ',' << points[p].z << ',' << worst[k].first << ','
                << f << ',' << ls[i] << ',' << bf[i] << '\n';
        }
    }
}

/// Per covered pixel S = gi::reference::irradianceNormalSensitivity of the frame's depth VALs (the
/// brute force's light, without near field) at the G-buffer's world position and normal; 0 elsewhere.
void normalSensitivityInto(mr::FramePipeline& pipeline, const cv::Mat& coverage, const cv::Mat& normals,
                           std::vector<gi::VirtualAreaLight>& vals, std::vector<std::uint32_t>& pixels,
                           cv::Mat& positions, cv::Mat& sensitivity) {
    pipeline.downloadDepthValsInto(vals, pixels);
    const gi::GBufferView& g = pipeline.renderer().gbuffer();
    gl::readTextureRgba32fInto(g.worldPosition, g.width, g.height, positions);
    sensitivity.create(coverage.size(), CV_32FC1);
    sensitivity.setTo(cv::Scalar(0.0));
    for (int v = 0; v < coverage.rows; ++v)
        for (int u = 0; u < coverage.cols; ++u) {
            if (!coverage.at<std::uint8_t>(v, u)) continue;
            const cv::Vec4f p = positions.at<cv::Vec4f>(v, u);
            const cv::Vec3f n = normals.at<cv::Vec3f>(v, u);
            sensitivity.at<float>(v, u) = float(gi::reference::irradianceNormalSensitivity(
                vals, glm::dvec3(p[0], p[1], p[2]), glm::dvec3(n[0], n[1], n[2])));
        }
}

/// --truth: the Embree truth with visibility at bunny pixels of this frame (RealDepthBenchOptions::truthReceivers),
/// one CSV line per pixel: the G-buffer's position and normal (so a run with other normals can be set beside it),
/// both techniques' luminance and the truth's with and without visibility in the same unit (2^exposure rho_d / pi E:
/// the template's materials are diffuse), and whether the composite shows the pixel.
void dumpTruth(const std::filesystem::path& path, mr::FramePipeline& pipeline, const mr::FrameOutput& out,
               const Pose& world_T_camera, double exposureScale, const RealDepthBenchOptions& options) {
    std::vector<gi::VirtualAreaLight> vals;
    std::vector<std::uint32_t> pixels;
    pipeline.downloadDepthValsInto(vals, pixels);
    const gi::GBufferView& g = pipeline.renderer().gbuffer();
    cv::Mat positions;
    gl::readTextureRgba32fInto(g.worldPosition, g.width, g.height, positions);
    const auto instances = pipeline.renderer().instances();
    if (instances.empty()) throw Error(path.string(), std::nullopt, "no virtual object");
    // The bunny's pixels: G-buffer positions inside its world bounding box (+1 mm); the cube stands ~10 cm away.
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (const glm::vec3& p : instances[0].mesh->positions) {
        const glm::vec3 w(instances[0].world_T_model * glm::vec4(p, 1.0f));
        lo = glm::min(lo, w);
        hi = glm::max(hi, w);
    }
    std::vector<cv::Point> bunny, chosen;
    for (int v = 0; v < positions.rows; ++v)
        for (int u = 0; u < positions.cols; ++u) {
            const cv::Vec4f p = positions.at<cv::Vec4f>(v, u);
            const glm::vec3 w(p[0], p[1], p[2]);
            if (out.coverage.at<std::uint8_t>(v, u) && p[3] > 0.0f && glm::all(glm::greaterThanEqual(w, lo - 1e-3f)) &&
                glm::all(glm::lessThanEqual(w, hi + 1e-3f)))
                bunny.emplace_back(u, v);
        }
    const std::size_t sampled = std::min<std::size_t>(bunny.size(), std::size_t(std::max(0, options.truthReceivers)));
    for (std::size_t i = 0; i < sampled; ++i) chosen.push_back(bunny[i * bunny.size() / sampled]);
    std::istringstream list(options.truthPixels);
    std::size_t extra = 0;
    for (std::string item; std::getline(list, item, ';');) {
        int u = -1, v = -1;
        if (std::sscanf(item.c_str(), "%d,%d", &u, &v) != 2 || u < 0 || v < 0 || u >= positions.cols ||
            v >= positions.rows || !out.coverage.at<std::uint8_t>(v, u))
            throw Error("--truth-pixels", std::nullopt, "'" + item + "' is not a covered pixel u,v");
        chosen.emplace_back(u, v);
        ++extra;
    }
    std::vector<gi::GroundTruthMesh> meshes;
    for (const gi::MeshInstance& m : instances) meshes.push_back({m.mesh, glm::dmat4(m.world_T_model)});
    const gi::RayTracedGroundTruth truth = gi::RayTracedGroundTruth::create(meshes);
    const glm::dvec3 eye = world_T_camera.translation();
    std::vector<gi::GroundTruthReceiver> receivers;
    for (const cv::Point& px : chosen) {
        const cv::Vec4f p = positions.at<cv::Vec4f>(px.y, px.x);
        const cv::Vec3f n = out.virtualNormals.at<cv::Vec3f>(px.y, px.x);
        gi::GroundTruthReceiver r;
        r.position = glm::dvec3(p[0], p[1], p[2]);
        r.normal = glm::normalize(glm::dvec3(n[0], n[1], n[2]));
        r.toViewer = glm::normalize(eye - r.position);
        r.material = instances[0].material;
        receivers.push_back(r);
    }
    std::vector<gi::GroundTruthResult> results(receivers.size());
    const std::size_t coarse = receivers.size() - extra;
    gi::GroundTruthSettings settings;
    settings.discRings = 4; // VALs ~1 cm apart at >= 10 cm from most receivers: 32 cells per disc
    settings.discSectors = 8;
    truth.compute(vals, std::span(receivers).first(coarse), std::span(results).first(coarse), settings);
    settings.discRings = 16; // contact pixels: VALs a few mm away
    settings.discSectors = 32;
    truth.compute(vals, std::span(receivers).subspan(coarse), std::span(results).subspan(coarse), settings);
    cv::Mat yLs, yBf;
    eval::luminanceInto(out.linearIndirect, yLs);
    eval::luminanceInto(out.linearIndirectReference, yBf);
    const glm::dvec3 reflect = exposureScale * glm::dvec3(instances[0].material.diffuseAlbedo) / 3.141592653589793;
    const auto luminance = [&](const glm::dvec3& e) {
        const glm::dvec3 c = reflect * e;
        return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
    };
    std::ofstream csv(path);
    csv << "u,v,x,y,z,normal_x,normal_y,normal_z,lightskin_Y,bruteforce_Y,truth_Y,truth_unoccluded_Y,visible\n";
    csv.precision(9);
    for (std::size_t i = 0; i < chosen.size(); ++i) {
        const cv::Point& px = chosen[i];
        const gi::GroundTruthReceiver& r = receivers[i];
        csv << px.x << ',' << px.y << ',' << r.position.x << ',' << r.position.y << ',' << r.position.z << ','
            << r.normal.x << ',' << r.normal.y << ',' << r.normal.z << ',' << yLs.at<float>(px.y, px.x) << ','
            << yBf.at<float>(px.y, px.x) << ',' << luminance(results[i].irradiance) << ','
            << luminance(results[i].unoccludedIrradiance) << ','
            << (out.visibleCoverage.at<std::uint8_t>(px.y, px.x) ? 1 : 0) << '\n';
    }
    if (!csv) throw Error(path.string(), std::nullopt, "cannot write");
}

/// One case over its frames; a stop ends it after the current frame (its results then over the frames run).
CaseResult runCase(const RealCase& c, const LightModel& model, double sink, const RealDepthBenchOptions& options,
                   StopCheck& stop) {
    const std::filesystem::path recording = std::filesystem::path(options.data) / c.recording;
    render::Scene scene = render::loadScene(options.scene);
    scene.gi.robustRealDepth = model.robust;
    scene.gi.robustIrradianceCap = model.irradianceCap;
    scene.gi.robustBuriedSparsePoints = model.buriedSparsePoints;
    scene.gi.robustNearField = model.nearField;
    // Frame 0: the surfaces the objects stand on, in the world frame of the case's pose mode.
    auto source = capture::openFrameSource(recording.string(), {});
    RgbdFrame first;
    if (!source->next(first)) throw Error(recording.string(), 0, "no frames");
    Pose world_T_camera0;
    if (c.pose == mr::PoseMode::GroundTruth) {
        if (!first.groundTruth_world_T_camera) throw Error(recording.string(), 0, "no ground-truth pose");
        world_T_camera0 = *first.groundTruth_world_T_camera;
    }
    const Anchor anchors[2] = {c.bunny, c.cube};
    const float scales[2] = {1.5f, 0.12f};
    glm::dvec3 bunnyPoint{0.0}, bunnyNormal{0.0};
    for (std::size_t i = 0; i < 2 && i < scene.objects.size(); ++i) {
        const SurfacePoint s = fitSurface(first, anchors[i], c.fitDepthWindow, recording.string());
        const glm::dvec3 p = world_T_camera0.transformPoint(s.position);
        const glm::dvec3 n = glm::normalize(world_T_camera0.rotation() * s.normal);
        scene.objects[i].world_T_model = placeOnSurface(meshBounds(scene.objects[i].mesh), scales[i], p, n, sink);
        if (i == 0) {
            bunnyPoint = p;
            bunnyNormal = n;
        }
    }
    const glm::dvec3 towardCamera = glm::normalize(world_T_camera0.translation() - bunnyPoint);
    if (!scene.lights.empty())
        scene.lights[0].position = glm::vec3(bunnyPoint + 0.8 * bunnyNormal + 0.3 * towardCamera);

    source = capture::openFrameSource(recording.string(), {});
    mr::PipelineOptions po;
    po.poseMode = c.pose;
    po.compare = false;
    po.view = render::DebugView::IndirectOnly;
    po.referenceIndirect = true;
    po.backend = gi::BackendSetting::Gl; // the rows are LightSkin on gl (their backend column), on any renderer
    auto pipeline = mr::FramePipeline::create(scene, source->info(), po);

    // Tracked points for flicker: every k-th vertex of both meshes (~1500 per mesh), world space.
    std::vector<glm::dvec3> points;
    for (const gi::MeshInstance& m : pipeline->renderer().instances()) {
        const std::size_t step = std::max<std::size_t>(1, m.mesh->vertexCount() / 1500);
        for (std::size_t i = 0; i < m.mesh->vertexCount(); i += step)
            points.emplace_back(m.world_T_model * glm::vec4(m.mesh->positions[i], 1.0f));
    }
    FlickerSeries flicker(points.size());

    CaseResult r;
    r.recording = c.name;
    r.model = model.name;
    r.sink = sink;
    RgbdFrame frame;
    mr::FrameOutput out;
    cv::Mat smooth, mapLs, mapBf, sensitivity, sensitiveSmooth, positions;
    std::vector<gi::VirtualAreaLight> vals;
    std::vector<std::uint32_t> valPixels;
    const std::filesystem::path imageFolder = std::filesystem::path(options.out) / "images";
    std::filesystem::create_directories(imageFolder);
    std::ofstream speckleCsv;
    if (options.maps) {
        char name[160];
        std::snprintf(name, sizeof name, "%s_%s_sink%.0fmm_speckle_pixels.csv", c.name.c_str(), model.name.c_str(),
                      sink * 1e3);
        speckleCsv.open(imageFolder / name);
        if (!speckleCsv) throw Error((imageFolder / name).string(), std::nullopt, "cannot write");
        speckleCsv
            << "frame,u,v,technique,Y,median5x5,Y_other_technique,normal_x,normal_y,normal_z,depth_m,real_depth_m,"
               "back_face\n";
    }
    while (r.frames < std::min(c.frames, options.maxFrames) && !stop() && source->next(frame)) {
        pipeline->process(frame, out);
        if (!out.world_T_camera || out.linearIndirect.empty() || out.linearIndirectReference.empty())
            throw Error(recording.string(), frame.index, "no pose or no GI in this frame");
        r.vals += out.valCount;
        // Speckle where the truth can be smooth: one surface patch per 5x5 window (normals within
        // kSmoothAngle, depth within 2 %; eval::smoothSurfaceMaskInto).
        eval::smoothSurfaceMaskInto(out.coverage, out.virtualNormals, out.virtualDepthMetres, kSmoothAngleDegrees, 0.02,
                                    smooth);
        // ... that the composite shows (eval/Speckle.h, "What the user sees"): hidden pixels out, windows whole.
        cv::bitwise_and(smooth, out.visibleCoverage, smooth);
        const bool maps = options.maps;
        const eval::SpeckleStats ls = eval::measureSpeckle(out.linearIndirect, out.coverage, maps ? &mapLs : nullptr,
                                                           smooth, true, out.backFacing);
        const eval::SpeckleStats bf = eval::measureSpeckle(out.linearIndirectReference, out.coverage,
                                                           maps ? &mapBf : nullptr, smooth, true, out.backFacing);
        if (maps) {
            dumpSpecklePixels(speckleCsv, frame, out, mapLs, mapBf);
            char name[200];
            std::snprintf(name, sizeof name, "%s_%s_sink%.0fmm_frame%lld", c.name.c_str(), model.name.c_str(),
                          sink * 1e3, static_cast<long long>(frame.index));
            writeRawLuminance(imageFolder / (std::string(name) + "_lightskin_Y.f32"), out.linearIndirect);
            writeRawLuminance(imageFolder / (std::string(name) + "_bruteforce_Y.f32"), out.linearIndirectReference);
            // ~11 MB per frame (VALs, two RGBA32F images): the first frame of each case only
            if (r.frames == 0) dumpValsAndGBuffer(imageFolder / name, *pipeline, frame.depth.cols);
            cv::Mat measured;
            cv::hconcat(mapLs, mapBf, measured);
            cv::imwrite((imageFolder / (std::string(name) + "_speckle_map.png")).string(), measured);
        }
        if (r.frames == 0 && (options.truthReceivers > 0 || !options.truthPixels.empty())) {
            char name[160];
            std::snprintf(name, sizeof name, "%s_%s_sink%.0fmm_truth.csv", c.name.c_str(), model.name.c_str(),
                          sink * 1e3);
            dumpTruth(imageFolder / name, *pipeline, out, *out.world_T_camera, std::exp2(double(scene.exposureStops)),
                      options);
        }
        normalSensitivityInto(*pipeline, out.coverage, out.virtualNormals, vals, valPixels, positions, sensitivity);
        eval::smoothSurfaceMaskInto(out.coverage, out.virtualNormals, out.virtualDepthMetres, kSmoothAngleDegrees, 0.02,
                                    sensitiveSmooth, sensitivity);
        cv::bitwise_and(sensitiveSmooth, out.visibleCoverage, sensitiveSmooth);
        accumulate(r.lightSkin.speckleSensitive, eval::measureSpeckle(out.linearIndirect, out.coverage, nullptr,
                                                                      sensitiveSmooth, true, out.backFacing));
        accumulate(r.brute.speckleSensitive, eval::measureSpeckle(out.linearIndirectReference, out.coverage, nullptr,
                                                                  sensitiveSmooth, true, out.backFacing));
        accumulate(r.lightSkin.speckle, ls);
        accumulate(r.brute.speckle, bf);
        accumulate(r.lightSkin.speckleMedian,
                   eval::measureSpeckle(out.linearIndirect, out.coverage, nullptr, smooth, false, out.backFacing));
        accumulate(r.brute.speckleMedian, eval::measureSpeckle(out.linearIndirectReference, out.coverage, nullptr,
                                                               smooth, false, out.backFacing));
        r.lightSkin.totalLight += coveredLuminance(out.linearIndirect, out.coverage);
        r.brute.totalLight += coveredLuminance(out.linearIndirectReference, out.coverage);
        if (r.frames == 0) {
            char name[160];
            std::snprintf(name, sizeof name, "%s_%s_sink%.0fmm_", c.name.c_str(), model.name.c_str(), sink * 1e3);
            writeIndirectPng(imageFolder / (std::string(name) + "lightskin.png"), out.linearIndirect, bf.meanLuminance);
            writeIndirectPng(imageFolder / (std::string(name) + "bruteforce.png"), out.linearIndirectReference,
                             bf.meanLuminance);
            if (maps) { // 0 outside, 64 measured, 255 speckle; LightSkin left, brute force right
                cv::Mat both;
                cv::hconcat(mapLs, mapBf, both);
                cv::imwrite((imageFolder / (std::string(name) + "speckle_map.png")).string(), both);
            }
        }
        if (c.flicker)
            flicker.addFrame(points, frame.colourIntrinsics, *out.world_T_camera, out.coverage, out.virtualDepthMetres,
                             out.linearIndirect, out.linearIndirectReference);
        ++r.frames;
    }
    if (c.flicker && r.frames >= 2) {
        if (options.maps)
            dumpWorstFlicker(imageFolder, c.name + "_" + model.name, sink, points, r.frames, flicker.lightSkinSeries(),
                             flicker.bruteForceSeries());
        const FlickerSeries::Result measured = flicker.measure();
        r.flickerMeasured = true;
        r.flickerSamples = measured.samples;
        r.flickerBrute = measured.bruteForce;
        r.flickerLightSkin = measured.lightSkin;
        r.excessFlicker = measured.excess;
    }
    gl::DebugOutput::throwIfErrors("bench-realdepth");
    return r;
}

std::string percent(double f) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3f %%", 100.0 * f);
    return b;
}

/// The flicker table as the bench JSON's temporal rows (BenchReport.h): per recording and sink one
/// sequence, LightSkin and the brute force under each light model, the brute force the reference.
std::vector<TemporalResult> temporalRows(const std::vector<CaseResult>& results) {
    std::vector<TemporalResult> rows;
    for (const CaseResult& r : results) {
        if (!r.flickerMeasured) continue;
        char sequence[160];
        std::snprintf(sequence, sizeof sequence, "%s, sink %.0f mm", r.recording.c_str(), r.sink * 1e3);
        TemporalResult brute{sequence,
                             "brute force (" + r.model + " light model)",
                             r.frames,
                             r.flickerSamples,
                             r.flickerBrute,
                             r.flickerBrute,
                             0.0,
                             "brute force",
                             std::string(gi::toString(gi::Backend::Gl))};
        TemporalResult lightSkin{sequence,
                                 "LightSkin (" + r.model + " light model)",
                                 r.frames,
                                 r.flickerSamples,
                                 r.flickerLightSkin,
                                 r.flickerBrute,
                                 r.excessFlicker,
                                 "LightSkin",
                                 std::string(gi::toString(gi::Backend::Gl))};
        rows.push_back(brute);
        rows.push_back(lightSkin);
    }
    return rows;
}

} // namespace

void runRealDepthBench(const RealDepthBenchOptions& options) {
    StopCheck stop(options.stopRequested);
    const auto started = std::chrono::steady_clock::now();
    Report report = startReport("bench-realdepth", options.maxFrames);
    auto context = gl::createHeadlessContext();
    report.renderer = context->describe();
    std::vector<LightModel> models;
    std::istringstream list(options.models);
    for (std::string m; std::getline(list, m, ',');) {
        if (m == "old")
            models.push_back({"old", false});
        else if (m == "robust")
            models.push_back({"robust", true});
        else if (m == "robust-nocap")
            models.push_back({"robust-nocap", true, false});
        else if (m == "robust-noburied")
            models.push_back({"robust-noburied", true, true, false});
        else if (m == "robust-area")
            models.push_back({"robust-area", true, true, true, true});
        else
            throw Error("--models", std::nullopt,
                        "unknown light model '" + m + "' (old, robust, robust-nocap, robust-noburied, robust-area)");
    }
    std::vector<CaseResult> results;
    for (const RealCase& c : realCases()) {
        if (!options.recordings.empty() &&
            ("," + options.recordings + ",").find("," + c.name + ",") == std::string::npos)
            continue;
        for (double sink : options.sinks)
            for (const LightModel& m : models) {
                if (stop()) break; // a stop stays asked: the loops around this one pass over their remaining values
                results.push_back(runCase(c, m, sink, options, stop));
                if (results.back().frames == 0 && stop.stopped()) { // stopped before its first frame
                    results.pop_back();
                    break;
                }
                const CaseResult& r = results.back();
                std::printf("%s, %s, sink %.0f mm, %d frames: LightSkin %s | brute force %s\n", r.recording.c_str(),
                            r.model.c_str(), r.sink * 1e3, r.frames, r.lightSkin.speckle.describe().c_str(),
                            r.brute.speckle.describe().c_str());
                std::fflush(stdout);
            }
    }
    // Total light is relative to the old model, or where it did not run to the first model listed
    // (e.g. --models robust,robust-area: the change G12 makes).
    std::string baseline = models.empty() ? "old" : models.front().name;
    for (const LightModel& m : models)
        if (m.name == "old") baseline = "old";
    std::ostringstream md;
    md << "| recording | sink | light model | frames | VALs/frame | speckle LightSkin | speckle brute force | black / "
          "blown (LS) | "
          "black / blown (BF) | total light LS vs "
       << baseline << " | total light BF vs " << baseline
       << " | median-only speckle LS / BF | sensitivity mask (proposal): speckle LS / BF (black LS / BF), interior "
          "|\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const CaseResult& r : results) {
        const CaseResult* old = nullptr;
        for (const CaseResult& o : results)
            if (o.recording == r.recording && o.sink == r.sink && o.model == baseline) old = &o;
        char row[640];
        std::snprintf(row, sizeof row,
                      "| %s | %.0f mm | %s | %d | %.0f | %s | %s | %zu / %zu | %zu / %zu | %s | %s | %s / %s | %s / %s "
                      "(%zu / %zu), %zu of %zu |\n",
                      r.recording.c_str(), r.sink * 1e3, r.model.c_str(), r.frames,
                      double(r.vals) / double(std::max(1, r.frames)),
                      percent(r.lightSkin.speckle.speckleFraction()).c_str(),
                      percent(r.brute.speckle.speckleFraction()).c_str(), r.lightSkin.speckle.blackPixels,
                      r.lightSkin.speckle.blownPixels, r.brute.speckle.blackPixels, r.brute.speckle.blownPixels,
                      old ? percent(r.lightSkin.totalLight / old->lightSkin.totalLight - 1.0).c_str() : "-",
                      old ? percent(r.brute.totalLight / old->brute.totalLight - 1.0).c_str() : "-",
                      percent(r.lightSkin.speckleMedian.speckleFraction()).c_str(),
                      percent(r.brute.speckleMedian.speckleFraction()).c_str(),
                      percent(r.lightSkin.speckleSensitive.speckleFraction()).c_str(),
                      percent(r.brute.speckleSensitive.speckleFraction()).c_str(),
                      r.lightSkin.speckleSensitive.blackPixels, r.brute.speckleSensitive.blackPixels,
                      r.brute.speckleSensitive.interiorPixels, r.brute.speckle.interiorPixels);
        md << row;
    }
    md << "\n| recording | sink | light model | frames | samples | flicker brute force | flicker LightSkin | excess "
          "flicker LightSkin |\n"
          "|---|---|---|---|---|---|---|---|\n";
    for (const CaseResult& r : results) {
        if (!r.flickerMeasured) continue;
        char row[256];
        std::snprintf(row, sizeof row, "| %s | %.0f mm | %s | %d | %zu | %.4f | %.4f | %.4f |\n", r.recording.c_str(),
                      r.sink * 1e3, r.model.c_str(), r.frames, r.flickerSamples, r.flickerBrute, r.flickerLightSkin,
                      r.excessFlicker);
        md << row;
    }
    report.interrupted = stop();
    if (report.interrupted) md << "\n" << interruptedLine("bench-realdepth") << "\n";
    std::printf("\n%s", md.str().c_str());
    std::fflush(stdout);
    std::ofstream(std::filesystem::path(options.out) / "realdepth.md") << md.str();
    // The flicker comparison as JSON and its plot (the speckle table stays in realdepth.md).
    report.temporal = temporalRows(results);
    report.loadEnd = loadAverage();
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    writeJsonAndPlots(report, options.out);
}

} // namespace lightskin::bench
