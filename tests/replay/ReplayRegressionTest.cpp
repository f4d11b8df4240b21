// The replay regression suite: runs `lightskin replay` on every sample recording (the
// synthetic ones in recordings/, real TUM fr2 frames and the real Kinect v1 .oni with a fixed pose,
// ICL-NUIM frames with their ground-truth trajectory) through capture -> depth filter -> pose -> VALs
// -> GI -> composite, headless, and checks what users see:
//   - chosen composite frames and one indirect-light frame against golden images, in linear space,
//     over the covered pixels only (the virtual content), relative to the indirect light the golden
//     holds (eval::compareWithGolden; on failure actual/golden/diff paths are printed); each golden
//     records the renderer from report.json, and another renderer fails the comparison;
//   - the thresholds catch a uniform 10 % change of the indirect light in every case (the indirect
//     scaled by 0.9 and 1.1, and switched off, must fail them), and local ones (20 % lost over a
//     quarter of the content, 10 % over half: a per-region metric), checked in every run;
//   - the pose against ground truth where known; no NaN/inf in the report or in the linear images
//     (replay counts them per frame in the float composite, before the 8-bit clamp);
//   - the indirect light is neither black nor saturated on the virtual content;
//   - the number of frames replayed equals the number recorded (or requested).
// Goldens hold a fixed region per recording around the virtual content, and in it only the virtual
// content and a 4 px band around it (its soft compositing band); the rest is the camera image
// passed through unchanged, which would only make the goldens large. The metrics count only the
// covered pixels (the content of this run or of the golden), so zeros cannot dilute them. The test
// checks that all virtual content lies inside the region. Regenerate: docs/TESTING.md.
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/eval/ColourSpace.h>
#include <lightskin/eval/GoldenImage.h>
#include <lightskin/tracking/TagDetector.h>
#include <lightskin/tracking/TagWorld.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <vector>

namespace fs = std::filesystem;

namespace lightskin::test {
namespace {

/// Runs `lightskin replay <arguments>`; stdout/stderr go to files in `scratch` (printed on failure).
int runLightskin(const std::string& arguments, const fs::path& scratch, const std::string& tag) {
    const std::string command = std::string(LIGHTSKIN_PROGRAM) + " replay " + arguments + " > " +
                                (scratch / (tag + ".stdout.txt")).string() + " 2> " +
                                (scratch / (tag + ".stderr.txt")).string();
    return test::runShell(command);
}

struct TruthPose {
    double t[3];
    double q[4]; // x y z w
};

double translationError(const nlohmann::json& pose, const TruthPose& truth) {
    double sum = 0.0;
    for (std::size_t i = 0; i < 3; ++i) {
        const double d = pose["translation"][i].get<double>() - truth.t[i];
        sum += d * d;
    }
    return std::sqrt(sum);
}

/// Angle between two rotations, degrees.
double rotationErrorDegrees(const nlohmann::json& pose, const TruthPose& truth) {
    double dot = 0.0, n1 = 0.0, n2 = 0.0;
    for (std::size_t i = 0; i < 4; ++i) {
        const double a = pose["rotationXYZW"][i].get<double>();
        dot += a * truth.q[i];
        n1 += a * a;
        n2 += truth.q[i] * truth.q[i];
    }
    const double c = std::min(1.0, std::abs(dot) / std::sqrt(n1 * n2));
    return 2.0 * std::acos(c) * 180.0 / 3.14159265358979323846;
}

/// Ground truth of a lightskin recording: frames.jsonl's world_T_camera per frame, and the frame
/// count from the end line (the recording's own count, independent of the reader).
std::vector<TruthPose> recordingTruth(const fs::path& folder, std::int64_t& recordedFrames) {
    std::vector<TruthPose> poses;
    std::ifstream index(folder / "frames.jsonl");
    recordedFrames = -1;
    for (std::string line; std::getline(index, line);) {
        const auto j = nlohmann::json::parse(line);
        if (j.contains("end")) recordedFrames = j["frames"].get<std::int64_t>();
        if (!j.contains("frame")) continue;
        const auto& p = j["world_T_camera"];
        TruthPose truth{};
        for (std::size_t i = 0; i < 3; ++i) truth.t[i] = p["translation"][i].get<double>();
        for (std::size_t i = 0; i < 4; ++i) truth.q[i] = p["rotationXYZW"][i].get<double>();
        poses.push_back(truth);
    }
    return poses;
}

/// Non-comment lines of a TUM list file (rgb.txt, groundtruth.txt).
std::vector<std::string> tumLines(const fs::path& path) {
    std::vector<std::string> lines;
    std::ifstream file(path);
    for (std::string line; std::getline(file, line);)
        if (!line.empty() && line[0] != '#') lines.push_back(line);
    return lines;
}

std::vector<TruthPose> tumTruth(const fs::path& path) {
    std::vector<TruthPose> poses;
    for (const std::string& line : tumLines(path)) {
        std::istringstream in(line);
        double stamp = 0.0;
        TruthPose truth{};
        in >> stamp >> truth.t[0] >> truth.t[1] >> truth.t[2] >> truth.q[0] >> truth.q[1] >> truth.q[2] >> truth.q[3];
        poses.push_back(truth);
    }
    return poses;
}

/// Every number in the report must be finite. nlohmann::json writes NaN/inf as null, so a null
/// where the report has numbers (poses of tracked frames, stage times) is a non-finite value too.
void expectFiniteNumbers(const nlohmann::json& j, const std::string& where, int& bad) {
    if (j.is_number_float() && !std::isfinite(j.get<double>())) {
        ADD_FAILURE() << "non-finite number at " << where;
        ++bad;
    }
    if (j.is_object())
        for (const auto& [key, value] : j.items()) expectFiniteNumbers(value, where + "/" + key, bad);
    if (j.is_array())
        for (std::size_t i = 0; i < j.size(); ++i) expectFiniteNumbers(j[i], where + "/" + std::to_string(i), bad);
}

cv::Mat readLinear(const fs::path& path) {
    const cv::Mat srgb = cv::imread(path.string(), cv::IMREAD_COLOR);
    if (srgb.empty()) throw std::runtime_error("cannot read " + path.string());
    cv::Mat linear;
    eval::srgb8ToLinearInto(srgb, linear);
    return linear;
}

std::string frameFile(std::int64_t index) {
    char name[32];
    std::snprintf(name, sizeof name, "%06lld.png", static_cast<long long>(index));
    return name;
}

/// Pixels showing virtual content: where the normals debug view differs from the final composite.
/// Real pixels are the same camera pixel in both runs (same input, same deterministic compositor);
/// virtual pixels show a normal as a colour in one and shaded radiance in the other. Eroded by one
/// pixel so that the blended silhouette (soft occlusion band) does not count.
cv::Mat virtualMask(const fs::path& finalPng, const fs::path& normalsPng) {
    const cv::Mat a = cv::imread(finalPng.string(), cv::IMREAD_COLOR),
                  b = cv::imread(normalsPng.string(), cv::IMREAD_COLOR);
    if (a.empty() || b.empty() || a.size() != b.size())
        throw std::runtime_error("cannot read " + finalPng.string() + " / " + normalsPng.string());
    cv::Mat diff, channels[3], mask;
    cv::absdiff(a, b, diff);
    cv::split(diff, channels);
    mask = cv::max(cv::max(channels[0], channels[1]), channels[2]) > 8;
    cv::erode(mask, mask, cv::Mat());
    return mask;
}

/// Goldens keep the virtual content plus this margin (its soft compositing band and anti-aliased
/// silhouette); camera pixels farther away are zeroed (they are the unchanged camera image; noisy
/// real photos would make the goldens large and dilute the metrics).
constexpr int kMaskMarginPx = 4;

/// `linear` inside `roi`, zero farther than kMaskMarginPx from the virtual content.
cv::Mat keepAround(const cv::Mat& linear, const cv::Mat& mask, const cv::Rect& roi) {
    cv::Mat around;
    cv::dilate(mask, around,
               cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * kMaskMarginPx + 1, 2 * kMaskMarginPx + 1)));
    cv::Mat out = cv::Mat::zeros(roi.size(), linear.type());
    linear(roi).copyTo(out, around(roi));
    return out;
}

/// The pixels a golden comparison counts, in `roi` coordinates: this run's virtual content united
/// with the golden's (its non-zero pixels shrunk by the kept margin, i.e. the content it was made
/// from), so that content that vanished or moved is compared too instead of dropping out.
cv::Mat coverage(const cv::Mat& mask, const cv::Rect& roi, const fs::path& golden) {
    cv::Mat covered = mask(roi).clone();
    if (!fs::exists(golden)) return covered;
    std::string renderer;
    double peak = 1.0;
    const cv::Mat image = eval::readLinearPng16(golden, renderer, peak);
    if (image.size() != roi.size()) return covered; // compareWithGolden reports the size mismatch
    cv::Mat channels[3], nonZero;
    cv::split(image, channels);
    nonZero = cv::max(cv::max(channels[0], channels[1]), channels[2]) > 0.0f;
    cv::erode(nonZero, nonZero,
              cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * kMaskMarginPx + 1, 2 * kMaskMarginPx + 1)));
    return covered | nonZero;
}

/// The indirect light scaled by `factor`: the composite without GI plus `factor` times what GI adds
/// to it (on the content the composite is direct + indirect, so their difference is the indirect
/// light as displayed), or the indirect view itself scaled.
cv::Mat scaleIndirect(const cv::Mat& withGi, const cv::Mat& withoutGi, double factor) {
    return withoutGi + factor * (withGi - withoutGi);
}

/// The columns from the covered pixels' left edge up to the one where `share` of the covered pixels (counted) lie
/// to the left: a band of the content holding that share of it.
cv::Mat leftShareOf(const cv::Mat& covered, double share) {
    const double total = double(cv::countNonZero(covered));
    cv::Mat part = cv::Mat::zeros(covered.size(), CV_8UC1);
    double counted = 0.0;
    for (int col = 0; col < covered.cols && counted < share * total; ++col) {
        const int inColumn = cv::countNonZero(covered.col(col));
        if (inColumn == 0) continue;
        covered.col(col).copyTo(part.col(col));
        counted += inColumn;
    }
    return part;
}

/// scaleIndirect() on the pixels of `part` only; the rest unchanged.
cv::Mat scaleIndirectOn(const cv::Mat& withGi, const cv::Mat& withoutGi, const cv::Mat& part, double factor) {
    cv::Mat changed = withGi.clone();
    scaleIndirect(withGi, withoutGi, factor).copyTo(changed, part);
    return changed;
}

/// Local changes every golden comparison must reject (thresholds and why: above cases()): the indirect light
/// 20 % lost over a quarter of the covered pixels, and 10 % lost or added over half of them.
struct LocalChange {
    double share, factor;
};
constexpr LocalChange kLocalChangesThatMustFail[] = {{0.25, 0.8}, {0.5, 0.9}, {0.5, 1.1}};

/// Factors applied to this run's indirect light that every golden comparison must reject: a
/// uniform 10 % change either way, and GI switched off (thresholds and why: above cases()).
constexpr double kIndirectScalesThatMustFail[] = {0.9, 1.1, 0.0};

/// `scene` copied to `out` with LightSkin's occlusion channel off and its file references (meshes,
/// the tag world) made absolute, so that the copy works from the scratch folder.
void writeSceneWithoutOcclusion(const fs::path& scene, const fs::path& out) {
    nlohmann::json j = nlohmann::json::parse(test::readText(scene));
    const fs::path folder = scene.parent_path();
    for (auto& object : j["objects"])
        if (object.contains("mesh"))
            object["mesh"] = (folder / object["mesh"].get<std::string>()).lexically_normal().string();
    if (j.contains("tracking") && j["tracking"].contains("file"))
        j["tracking"]["file"] = (folder / j["tracking"]["file"].get<std::string>()).lexically_normal().string();
    j["gi"]["occlusion"] = false;
    std::ofstream(out) << j.dump(2);
}

/// Largest mean relative error |LightSkin - brute force| / brute force (luminance, summed over the
/// virtual content; replay's `--view error`) that a working GI may show. Derived from what must be
/// caught, like the golden limit: a GI that silently does nothing reads exactly 1 (|0 - b| / b),
/// one that delivers half of its light 0.5, and the limit is half of what "nothing" reads. What a
/// working LightSkin may differ from the brute force on the same VALs (occlusion off on both sides,
/// so only the sparse gather and the eq. 12-13 interpolation differ) has no tight bound on these
/// scenes: the objects rest on real surfaces, where the smoothing model of gi_truth_gl_test
/// diverges (l -> 0 at contact), and the cube is glossy (k = 30); the near-contact test's derived
/// budget (tests/gi/lightskin/NearContactGLTest.cpp: 20 % of the truth in total for LightSkin, 12 % for
/// the brute force) puts a working technique well inside 0.5.
constexpr double kMaxRelativeErrorVsBruteForce = 0.5;

/// A lower bound on the pixels of virtual content in a frame, from the scene's object named "cube"
/// (a unit cube mesh, meshes/cube.obj, scaled by `scale` = its edge a, centred at `translation`)
/// and the camera position of the frame (replay's world_T_camera) and the source's intrinsics
/// (replaces measured minimums). Derivation: every parallel projection of a cube covers at least
/// one face, a^2 (its projected area is a^2 (|n_x| + |n_y| + |n_z|) >= a^2); seen from the camera
/// no point of it is farther than r_far = |centre - camera| + a sqrt(3) / 2, so it subtends at
/// least a^2 / r_far^2 sr, and a pixel subtends at most 1 / (|f_x f_y|) sr (at the principal
/// point; less off-axis): >= |f_x f_y| a^2 / r_far^2 pixels, whatever the view direction. The
/// other objects only add pixels (one hiding the cube shows itself). Taken off: virtualMask()'s
/// one-pixel erosion, at most the outline's length, <= pi x the image diameter (convex outline)
/// <= pi sqrt(3) a sqrt(|f_x f_y|) / r_near pixels, r_near = |centre - camera| - a sqrt(3) / 2.
/// Assumes what the scenes are made for: the cube in view and not hidden by real surfaces. An animated cube
/// ("animation" keys instead of "transform") moves along the segments between its keys' translations: the
/// distance to the camera is convex along each, so it is at most the largest key distance (for r_far) and at
/// least the smallest point-to-segment distance (for r_near); its edge is the smallest key scale for the area
/// and the largest for the outline.
double cubePixelLowerBound(const nlohmann::json& scene, const nlohmann::json& world_T_camera,
                           const CameraIntrinsics& K) {
    const auto vec3 = [](const nlohmann::json& v) {
        return glm::dvec3(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
    };
    const glm::dvec3 camera = vec3(world_T_camera["translation"]);
    for (const auto& object : scene["objects"]) {
        if (object.value("name", std::string()) != "cube") continue;
        std::vector<nlohmann::json> keys;
        if (object.contains("animation"))
            for (const auto& key : object["animation"]["keys"]) keys.push_back(key);
        else
            keys.push_back(object["transform"]);
        double aMin = 1e30, aMax = 0.0, rFar = 0.0, rNear = 1e30;
        for (std::size_t k = 0; k < keys.size(); ++k) {
            const double a = keys[k]["scale"].get<double>();
            aMin = std::min(aMin, a);
            aMax = std::max(aMax, a);
            const glm::dvec3 p = vec3(keys[k]["translation"]);
            rFar = std::max(rFar, glm::length(p - camera));
            const glm::dvec3 q = k + 1 < keys.size() ? vec3(keys[k + 1]["translation"]) : p;
            const double along = glm::dot(q - p, q - p) > 0.0
                                     ? std::clamp(glm::dot(camera - p, q - p) / glm::dot(q - p, q - p), 0.0, 1.0)
                                     : 0.0;
            rNear = std::min(rNear, glm::length(p + along * (q - p) - camera));
        }
        const double f2 = std::abs(K.fx * K.fy);
        const double far = rFar + aMax * std::sqrt(3.0) / 2.0, near = rNear - aMax * std::sqrt(3.0) / 2.0;
        const double area = f2 * aMin * aMin / (far * far);
        const double outline = 3.14159265358979323846 * std::sqrt(3.0) * aMax * std::sqrt(f2) / near;
        return area - outline;
    }
    ADD_FAILURE() << "the scene has no object named cube";
    return 0.0;
}

enum class Truth { None, RecordingIndex, TumGroundTruth };

struct ReplayCase {
    std::string name;
    fs::path recording; ///< relative to the source dir
    fs::path scene;     ///< relative to the source dir
    std::string pose;   ///< --pose
    std::int64_t maxFrames = -1;
    std::vector<std::int64_t> goldenFrames; ///< composite frames compared with goldens
    std::int64_t indirectFrame = 0;         ///< the frame whose indirect-light view is compared
    std::int64_t recordedFrames = 0;        ///< counted independently of the reader (see each case)
    Truth truth = Truth::None;
    bool valsExpected = true; ///< depth registered to colour: VALs and GI exist
    eval::GoldenThresholds composite, indirect;
    /// Compared region: the bounding box of the virtual content in the chosen frames (dilated 8 px),
    /// measured when the goldens were made, rounded out by a few pixels.
    cv::Rect roi;
};

void PrintTo(const ReplayCase& c, std::ostream* os) { *os << c.name; }

class ReplayRegression : public ::testing::TestWithParam<ReplayCase> {};

TEST_P(ReplayRegression, MatchesGoldensAndGroundTruth) {
    const ReplayCase& c = GetParam();
    const fs::path root = sourceDir(), scratch = scratchDir("replay_" + c.name),
                   goldens = root / "tests" / "replay" / "goldens";
    std::string frameList;
    for (const std::int64_t f : c.goldenFrames) frameList += (frameList.empty() ? "" : ",") + std::to_string(f);
    if (std::find(c.goldenFrames.begin(), c.goldenFrames.end(), c.indirectFrame) == c.goldenFrames.end())
        frameList += "," + std::to_string(c.indirectFrame);
    const std::string common = (root / c.recording).string() + " --scene " + (root / c.scene).string() + " --pose " +
                               c.pose + " --no-video --write-frames " + frameList +
                               (c.maxFrames >= 0 ? " --max-frames " + std::to_string(c.maxFrames) : "") +
                               // The goldens pin the virtual content's light; the differential's change of the real
                               // pixels around it is pinned by tests/apps/DifferentialPipelineTest.cpp and gi/lights.
                               " --differential off" +
                               // The goldens are the GL backend's on every renderer (gi.backend "auto" takes the CPU
                               // on llvmpipe; apps_cpu_backend_test holds the CPU backend to the GL one).
                               " --backend gl";
    // Three runs over the same frames: the final composite (with the without-GI comparison), the
    // indirect light alone, and the normals (for the virtual-content mask).
    for (const char* view : {"final", "indirect", "normals"}) {
        const std::string args = common + " --view " + view + " --out " + (scratch / view).string() +
                                 (std::string(view) == "final" ? "" : " --no-compare");
        ASSERT_EQ(runLightskin(args, scratch, view), 0)
            << "lightskin replay " << args << "\n"
            << test::readText(scratch / (std::string(view) + ".stderr.txt"));
    }
    // A fourth run against an independent estimate of the indirect light: the brute force (every VAL
    // at every pixel, no sparse points, no interpolation) on the same VALs and frame, replay's error
    // view, with occlusion off (the brute force has none), up to the indirect frame.
    if (c.valsExpected) {
        writeSceneWithoutOcclusion(root / c.scene, scratch / "scene-without-occlusion.json");
        const std::string args = (root / c.recording).string() + " --scene " +
                                 (scratch / "scene-without-occlusion.json").string() + " --pose " + c.pose +
                                 " --no-video --no-compare --differential off --backend gl --view error " +
                                 "--write-frames " + std::to_string(c.indirectFrame) + " --max-frames " +
                                 std::to_string(c.indirectFrame + 1) + " --out " + (scratch / "error").string();
        ASSERT_EQ(runLightskin(args, scratch, "error"), 0) << "lightskin replay " << args << "\n"
                                                           << test::readText(scratch / "error.stderr.txt");
    }
    const nlohmann::json report = nlohmann::json::parse(test::readText(scratch / "final" / "report.json"));
    const std::string renderer = report["renderer"].get<std::string>();

    // Frame counts: the reader sees what was recorded, and replay processes all of it (or what was asked).
    const std::int64_t expectedRead = c.maxFrames >= 0 ? std::min(c.maxFrames, c.recordedFrames) : c.recordedFrames;
    EXPECT_EQ(report["framesInSource"].get<std::int64_t>(), c.recordedFrames);
    EXPECT_EQ(report["framesRead"].get<std::int64_t>(), expectedRead);
    ASSERT_EQ(std::int64_t(report["frames"].size()), expectedRead);
    EXPECT_FALSE(report["interrupted"].get<bool>());
    EXPECT_EQ(report["technique"], "lightskin");
    EXPECT_EQ(report["giBackend"], "gl");
    EXPECT_EQ(report["poseMode"], c.pose);

    // No NaN/inf anywhere in the report; poses and stage times present as numbers.
    int bad = 0;
    expectFiniteNumbers(report, "", bad);
    std::vector<TruthPose> truth;
    std::int64_t ignored = 0;
    if (c.truth == Truth::RecordingIndex) truth = recordingTruth(root / c.recording, ignored);
    if (c.truth == Truth::TumGroundTruth) truth = tumTruth(root / c.recording / "groundtruth.txt");
    for (std::size_t i = 0; i < report["frames"].size(); ++i) {
        const auto& f = report["frames"][i];
        EXPECT_EQ(f["index"].get<std::int64_t>(), std::int64_t(i));
        // Frames are labelled by what placed the content: the tracker's state, or the pose mode.
        EXPECT_EQ(f["tracking"], report["poseMode"] == "tracking" ? "tracking" : report["poseMode"].get<std::string>()) << f.dump();
        ASSERT_TRUE(f["world_T_camera"].is_object()) << f.dump();
        for (std::size_t k = 0; k < 3; ++k) EXPECT_TRUE(f["world_T_camera"]["translation"][k].is_number()) << f.dump();
        for (std::size_t k = 0; k < 4; ++k) EXPECT_TRUE(f["world_T_camera"]["rotationXYZW"][k].is_number()) << f.dump();
        for (const char* group : {"cpuMs", "gpuMs"})
            for (const auto& [stage, ms] : f[group].items())
                EXPECT_TRUE(ms.is_number() && ms.get<double>() >= 0.0) << stage << " " << f.dump();
        if (c.valsExpected) {
            EXPECT_GT(f["vals"].get<int>(), 100) << f.dump();
        } else {
            EXPECT_EQ(f["vals"].get<int>(), 0) << "this source was unregistered; update the case if it now has VALs";
        }
        // Pose against ground truth: the pipeline must carry the recorded pose through exactly
        // (1e-6 m, 1e-4 degrees: double-precision round trip through JSON and quaternions).
        if (c.truth != Truth::None) {
            ASSERT_LT(i, truth.size());
            EXPECT_LT(translationError(f["world_T_camera"], truth[i]), 1e-6) << f.dump();
            EXPECT_LT(rotationErrorDegrees(f["world_T_camera"], truth[i]), 1e-4) << f.dump();
        } else {
            // --pose fixed: the world is the camera frame.
            const TruthPose identity{{0, 0, 0}, {0, 0, 0, 1}};
            EXPECT_LT(translationError(f["world_T_camera"], identity), 1e-12);
            EXPECT_LT(rotationErrorDegrees(f["world_T_camera"], identity), 1e-6);
        }
    }

    // Composite frames against goldens, linear, around the virtual content.
    const nlohmann::json scene = nlohmann::json::parse(test::readText(root / c.scene));
    const CameraIntrinsics intrinsics =
        capture::openFrameSource((root / c.recording).string())->info().colourIntrinsics;
    for (const std::int64_t index : c.goldenFrames) {
        SCOPED_TRACE("frame " + std::to_string(index));
        const cv::Mat mask = virtualMask(scratch / "final" / "frames" / frameFile(index),
                                         scratch / "normals" / "frames" / frameFile(index));
        const double minVirtualPixels =
            cubePixelLowerBound(scene, report["frames"][std::size_t(index)]["world_T_camera"], intrinsics);
        EXPECT_GT(minVirtualPixels, 0.0) << "the bound must say something";
        EXPECT_GE(double(cv::countNonZero(mask)), minVirtualPixels) << "too little virtual content visible";
        std::printf("%s frame %lld: %d virtual pixels, at least %.0f from the cube\n", c.name.c_str(),
                    static_cast<long long>(index), cv::countNonZero(mask), minVirtualPixels);
        const cv::Mat linear = readLinear(scratch / "final" / "frames" / frameFile(index));
        // The virtual content must lie inside the compared region (else the region is stale).
        EXPECT_EQ(cv::countNonZero(mask(c.roi)), cv::countNonZero(mask)) << "virtual content outside the golden region";
        const cv::Mat actual = keepAround(linear, mask, c.roi);
        const std::string name = c.name + "_final_" + std::to_string(index);
        const cv::Mat covered = coverage(mask, c.roi, goldens / (name + ".png"));
        // The same frame without GI (the right half of replay's comparison image), same mask: the
        // baseline that makes the metric relative to the indirect light in the composite.
        cv::Mat withoutGi;
        if (c.valsExpected) {
            const cv::Mat sideBySide = readLinear(scratch / "final" / "compare" / frameFile(index));
            withoutGi = keepAround(sideBySide(cv::Rect(linear.cols, 0, linear.cols, linear.rows)).clone(), mask, c.roi);
        }
        const eval::GoldenResult result = eval::compareWithGolden(actual, goldens, name, c.composite,
                                                                  scratch / "golden", {renderer, covered, withoutGi});
        EXPECT_TRUE(result.passed) << result.describe();
        std::printf("%s: %s\n", name.c_str(), result.describe().c_str());
        // The thresholds must catch a uniform 10 % change of the indirect light (and GI switched
        // off): each scaled composite must fail. (Only where the source has VALs, i.e. GI shows.)
        if (c.valsExpected && !result.goldenMissing) {
            for (const double factor : kIndirectScalesThatMustFail) {
                const cv::Mat scaled = scaleIndirect(actual, withoutGi, factor);
                const eval::GoldenResult changed = eval::compareWithGolden(
                    scaled, goldens, name, c.composite, scratch / ("indirect_x" + std::to_string(factor)),
                    {renderer, covered, withoutGi});
                EXPECT_FALSE(changed.passed) << "thresholds too loose to see the indirect light scaled by " << factor
                                             << ": " << changed.describe();
                std::printf("%s, indirect x %.1f: %s\n", name.c_str(), factor, changed.error.describe().c_str());
            }
            for (const LocalChange& local : kLocalChangesThatMustFail) {
                const cv::Mat scaled =
                    scaleIndirectOn(actual, withoutGi, leftShareOf(covered, local.share), local.factor);
                const eval::GoldenResult changed = eval::compareWithGolden(
                    scaled, goldens, name, c.composite, scratch / "indirect_local", {renderer, covered, withoutGi});
                EXPECT_FALSE(changed.passed)
                    << "thresholds too loose to see the indirect light scaled by " << local.factor << " over "
                    << local.share << " of the content: " << changed.describe();
                std::printf("%s, indirect x %.1f over %.2f of the content: %s\n", name.c_str(), local.factor,
                            local.share, changed.error.describe().c_str());
            }
        }
    }

    // Indirect light on the virtual content: not black, not saturated, and against its golden.
    {
        const std::int64_t index = c.indirectFrame;
        SCOPED_TRACE("indirect, frame " + std::to_string(index));
        const cv::Mat mask = virtualMask(scratch / "final" / "frames" / frameFile(index),
                                         scratch / "normals" / "frames" / frameFile(index));
        const cv::Mat srgb =
            cv::imread((scratch / "indirect" / "frames" / frameFile(index)).string(), cv::IMREAD_COLOR);
        ASSERT_FALSE(srgb.empty());
        const cv::Mat linear = readLinear(scratch / "indirect" / "frames" / frameFile(index));
        // NaN/inf in the indirect view's linear image (the PNG cannot show them): counted by replay.
        const nlohmann::json indirectReport =
            nlohmann::json::parse(test::readText(scratch / "indirect" / "report.json"));
        EXPECT_EQ(indirectReport["linearNanPixels"].get<std::int64_t>(), 0);
        EXPECT_EQ(indirectReport["linearInfPixels"].get<std::int64_t>(), 0);
        cv::Mat grey;
        cv::cvtColor(linear, grey, cv::COLOR_BGR2GRAY);
        const double mean = cv::mean(grey, mask)[0];
        cv::Mat channels[3], saturated;
        cv::split(srgb, channels);
        saturated = (cv::max(cv::max(channels[0], channels[1]), channels[2]) >= 254) & mask;
        const double saturatedFraction = double(cv::countNonZero(saturated)) / std::max(1, cv::countNonZero(mask));
        if (c.valsExpected) {
            // Not black (any lit VAL in front of the content gives it light), and quantitatively
            // against the brute force on the same VALs (derivation at kMaxRelativeErrorVsBruteForce):
            EXPECT_GT(mean, 0.0) << "indirect light is black on the virtual content";
            const nlohmann::json errorReport = nlohmann::json::parse(test::readText(scratch / "error" / "report.json"));
            ASSERT_GT(std::int64_t(errorReport["frames"].size()), index);
            const auto& errorFrame = errorReport["frames"][std::size_t(index)];
            ASSERT_TRUE(errorFrame.contains("meanRelativeErrorVsBruteForce")) << errorFrame.dump();
            const double errorVsBrute = errorFrame["meanRelativeErrorVsBruteForce"].get<double>();
            // replay reports 0 when the brute force itself is black: no agreement to count on
            EXPECT_GT(errorVsBrute, 0.0) << "the brute force is black too, or equal to LightSkin bit for bit";
            EXPECT_LT(errorVsBrute, kMaxRelativeErrorVsBruteForce)
                << "LightSkin's indirect light against the brute force's";
            std::printf("%s: |LightSkin - brute force| / brute force (occlusion off) %.4f (limit %.2f)\n",
                        c.name.c_str(), errorVsBrute, kMaxRelativeErrorVsBruteForce);
            // Clipped pixels would mean the indirect light (or the exposure) blew up. Measured:
            // 0 on all recordings except icl-nuim (0.5%: the bunny's edge facing the sunlit window).
            EXPECT_LT(saturatedFraction, 0.01) << "indirect light saturated on the virtual content";
        } else {
            // No VALs: no indirect light at all.
            EXPECT_LT(mean, 1e-3);
        }
        const std::string name = c.name + "_indirect_" + std::to_string(index);
        const cv::Mat covered = coverage(mask, c.roi, goldens / (name + ".png"));
        const cv::Mat actual = keepAround(linear, mask, c.roi);
        const eval::GoldenResult result =
            eval::compareWithGolden(actual, goldens, name, c.indirect, scratch / "golden", {renderer, covered, {}});
        EXPECT_TRUE(result.passed) << result.describe();
        std::printf("%s: %s; mean %.4f, saturated %.4f over %d virtual pixels\n", name.c_str(),
                    result.describe().c_str(), mean, saturatedFraction, cv::countNonZero(mask));
        if (c.valsExpected && !result.goldenMissing) {
            for (const double factor : kIndirectScalesThatMustFail) {
                const eval::GoldenResult changed =
                    eval::compareWithGolden(actual * factor, goldens, name, c.indirect,
                                            scratch / ("indirect_x" + std::to_string(factor)), {renderer, covered, {}});
                EXPECT_FALSE(changed.passed) << "thresholds too loose to see the indirect light scaled by " << factor
                                             << ": " << changed.describe();
                std::printf("%s x %.1f: %s\n", name.c_str(), factor, changed.error.describe().c_str());
            }
            const cv::Mat none = cv::Mat::zeros(actual.size(), actual.type());
            for (const LocalChange& local : kLocalChangesThatMustFail) {
                const cv::Mat scaled = scaleIndirectOn(actual, none, leftShareOf(covered, local.share), local.factor);
                const eval::GoldenResult changed = eval::compareWithGolden(
                    scaled, goldens, name, c.indirect, scratch / "indirect_local", {renderer, covered, {}});
                EXPECT_FALSE(changed.passed)
                    << "thresholds too loose to see the indirect light scaled by " << local.factor << " over "
                    << local.share << " of the content: " << changed.describe();
                std::printf("%s x %.1f over %.2f of the content: %s\n", name.c_str(), local.factor, local.share,
                            changed.error.describe().c_str());
            }
        }
    }
}

// Thresholds. The metric is the relative MAE over the covered pixels (the virtual content of this
// run or of the golden), relative to the signal the golden must resolve: sum |actual - golden| /
// sum |golden - without-GI| for composites (the indirect light as it shows in the composite), sum
// |actual - golden| / sum |golden| for the indirect view. A uniform change of the indirect light by
// a factor k reads |k - 1| exactly (eval::ImageError; tests/eval), whatever the direct light, the
// camera image or the zeros around the content, so:
// - maxRelativeMeanAbsoluteError 0.05 = half of the 0.10 a uniform 10 % change reads. Each run
//   checks it: the indirect scaled by 0.9 and 1.1 (and 0, GI off) must fail in every case. The
//   other half is the room for what may legitimately differ: run to run (one 8-bit sRGB step at a
//   pixel now and then, ~1e-6 of the signal) and another Mesa/LLVM (llvmpipe reproduces bit for bit
//   only within one version; shader arithmetic in the last bits, a silhouette pixel). Content that
//   moved or vanished is compared against the golden's content (coverage()), i.e. against the whole
//   composite, which is 2-10x the indirect light: it fails far above 0.05. A local defect fails when
//   it removes >= 5 % of the indirect light's sum (a hole of >= 0.5-2.5 % of the content's pixels).
// - No limit on max, MAE, relMSE or SSIM (printed): none of them is derived from what must be
//   caught, and a uniform 10 % change moves SSIM by < 0.001 (its luminance term for y = 0.9x is
//   2 * 0.9 / 1.81 = 0.9994). Single-pixel NaN/inf are counted by replay and asserted to be 0.
// - Another renderer than the golden's sidecar names fails (promote after review, docs/TESTING.md).
// - maxRegionRelativeMeanAbsoluteError 0.05, the same metric per region (3 x 3 cells of the covered pixels'
//   bounding box, eval::kGoldenRegionGrid; cells with fewer than half their share of the pixels are skipped, so
//   4-5 of the 9 count on these silhouettes; a cell's signal is floored at 0.1 of the image's mean). The whole-
//   image metric dilutes a local change by its share: 20 % of the indirect light lost over a quarter of the
//   content reads 0.033-0.068 there and passes its limit on four of the seven goldens. A change by a factor k over
//   a whole cell reads |k - 1| there, so 0.05 is again half of a 10 % change; a band holding a quarter of the
//   content reaches over most of the left cells, so 20 % lost there reads 0.07-0.20 (printed), and 10 % over half
//   of the content covers the left cells whole (0.07-0.10). Each run checks both (kLocalChangesThatMustFail; the
//   same on the goldens alone: eval_test GoldenImageTest.RegionMetricCatchesLocalLossesOnTheReplayGoldens). Room
//   for what may legitimately differ: the unchanged runs read <= 0.0053 per region (synth_pan; the others <=
//   0.0024), 10x below the limit; a cell holds >= 1/18 of the content (>= 50 px on the smallest cubes, ~1000 px),
//   so a single silhouette pixel off by the largest difference seen (0.17 linear, about the mean indirect light
//   per pixel) reads <= 1/50 = 0.02 there.
eval::GoldenThresholds relativeMaeAtMost(double limit) {
    eval::GoldenThresholds t;
    t.maxRelativeMeanAbsoluteError = limit;
    t.maxRegionRelativeMeanAbsoluteError = limit;
    return t;
}
const eval::GoldenThresholds kComposite = relativeMaeAtMost(0.05);
const eval::GoldenThresholds kIndirect = kComposite;

std::vector<ReplayCase> cases() {
    std::vector<ReplayCase> all;
    auto add = [&all](ReplayCase c) { all.push_back(std::move(c)); };
    std::int64_t orbitFrames = 0, panFrames = 0, cleanFrames = 0;
    const fs::path root = sourceDir();
    recordingTruth(root / "recordings" / "synth-orbit", orbitFrames);
    recordingTruth(root / "recordings" / "synth-pan", panFrames);
    recordingTruth(root / "recordings" / "synth-clean-channels", cleanFrames);
    // Synthetic recordings with their exact ground-truth poses (tracking is checked separately
    // below: goldens of a tracked run would change with every tracker change, measuring the
    // tracker rather than the rendering).
    add({.name = "synth_orbit",
         .recording = "recordings/synth-orbit",
         .scene = "recordings/scenes/orbit.json",
         .pose = "ground-truth",
         .maxFrames = 3,
         .goldenFrames = {0, 2},
         .indirectFrame = 2,
         .recordedFrames = orbitFrames,
         .truth = Truth::RecordingIndex,
         .composite = kComposite,
         .indirect = kIndirect,
         .roi = cv::Rect{100, 94, 164, 72}});
    // The main job's scene: the cube slides and turns by keyframes (orbit_moving.json); frame 10 (t = 1/3 s) has
    // it half way between its first two keys, 15 cm from where it starts and turned 46 degrees.
    add({.name = "synth_orbit_moving",
         .recording = "recordings/synth-orbit",
         .scene = "recordings/scenes/orbit_moving.json",
         .pose = "ground-truth",
         .maxFrames = 11,
         .goldenFrames = {10},
         .indirectFrame = 10,
         .recordedFrames = orbitFrames,
         .truth = Truth::RecordingIndex,
         .composite = kComposite,
         .indirect = kIndirect,
         .roi = cv::Rect{96, 99, 144, 56}});
    add({.name = "synth_pan",
         .recording = "recordings/synth-pan",
         .scene = "recordings/scenes/pan.json",
         .pose = "ground-truth",
         .maxFrames = 2,
         .goldenFrames = {1},
         .indirectFrame = 1,
         .recordedFrames = panFrames,
         .truth = Truth::RecordingIndex,
         .composite = kComposite,
         .indirect = kIndirect,
         .roi = cv::Rect{48, 52, 196, 98}});
    // All 4 frames: the full-length check of "frames replayed == frames recorded".
    add({.name = "synth_clean_channels",
         .recording = "recordings/synth-clean-channels",
         .scene = "recordings/scenes/clean_channels.json",
         .pose = "ground-truth",
         .maxFrames = -1,
         .goldenFrames = {3},
         .indirectFrame = 3,
         .recordedFrames = cleanFrames,
         .truth = Truth::RecordingIndex,
         .composite = kComposite,
         .indirect = kIndirect,
         .roi = cv::Rect{24, 42, 104, 40}});
    // Real TUM fr2/desk frames, fixed pose (content placed in camera coordinates). Both frames.
    add({.name = "tum_fr2_desk",
         .recording = "tests/data/tum-fr2-desk",
         .scene = "recordings/scenes/camera_frame.json",
         .pose = "fixed",
         .maxFrames = -1,
         .goldenFrames = {1},
         .indirectFrame = 1,
         .recordedFrames = std::int64_t(tumLines(root / "tests/data/tum-fr2-desk/rgb.txt").size()),
         .truth = Truth::None,
         .composite = kComposite,
         .indirect = kIndirect,
         .roi = cv::Rect{188, 216, 256, 172}});
    // ICL-NUIM living room with its ground-truth trajectory (groundtruth.txt), all 5 frames.
    add({.name = "icl_nuim",
         .recording = "tests/data/icl-nuim-open3d",
         .scene = "recordings/scenes/icl_living_room.json",
         .pose = "ground-truth",
         .maxFrames = -1,
         .goldenFrames = {4},
         .indirectFrame = 4,
         .recordedFrames = std::int64_t(tumLines(root / "tests/data/icl-nuim-open3d/rgb.txt").size()),
         .truth = Truth::TumGroundTruth,
         .composite = kComposite,
         .indirect = kIndirect,
         .roi = cv::Rect{184, 240, 204, 128}});
    // The real Kinect v1 .oni, fixed pose, first 2 of its 12 frames (12: tests/data/oni-kinect-v1/README.md),
    // its unregistered depth registered in software (capture/Registration.h), a bunny and a cube on
    // its floor (oni_room.json). Every frame of it is checked for VALs and visible GI below.
    add({.name = "oni_kinect_v1",
         .recording = "tests/data/oni-kinect-v1/3dj_test.oni",
         .scene = "recordings/scenes/oni_room.json",
         .pose = "fixed",
         .maxFrames = 2,
         .goldenFrames = {1},
         .indirectFrame = 1,
         .recordedFrames = 12,
         .truth = Truth::None,
         .composite = kComposite,
         .indirect = kIndirect,
         .roi = cv::Rect{216, 308, 152, 160}});
    return all;
}

INSTANTIATE_TEST_SUITE_P(Recordings, ReplayRegression, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<ReplayCase>& param) { return param.param.name; });

// AprilTag tracking through the whole pipeline: the tracked pose against the recordings' exact
// ground truth, and the tracking state of every frame against what the detector decodes in it
// (the scene's own detector settings, run here on the recording's frames). The tracker's accuracy
// is tested in tests/tracking; these catch a broken pose path (wrong frame, inverted pose, detector
// settings not reaching the tracker, a tracker that claims to track without a tag).
//
// Bounds from the pose-error budget (docs/TESTING.md "Pose-error budget": content displaced by at
// most 1.5 degrees of view angle at 2 sigma; TrackerSettings::maxWorldCornerStdPx is derived from
// it), asserted at 3 sigma (1.5x): rotation error <= 2.25 degrees, camera position error across the
// true viewing direction <= 1.5 z tan(1.5 deg), z = the distance to the nearest world tag (the
// content stands by the tags). Along the view an error only rescales the image about its centre,
// which the budget does not bound (printed, not asserted). replay's poses are filtered (One-Euro):
// its lag is part of the error and must fit the same budget.
constexpr double kBudgetDegrees = 1.5;
constexpr double kSigmasOverBudgetSigmas = 1.5; // 3 sigma asserted / 2 sigma budgeted
constexpr int kMaxHeldFrames = 10;              // TrackerSettings::maxHeldFrames (default; the scenes keep it)

struct TrackedFrame {
    std::string state;
    double rotationErrorDegrees = -1.0, acrossErrorMetres = -1.0, alongErrorMetres = 0.0; // < 0: no pose
    double acrossBoundMetres = 0.0;
    double translationError = -1.0; // metres, < 0: no pose (the report's poseError must equal it)
};

glm::dvec3 rotate(const double q[4], const glm::dvec3& v) { // q = x y z w
    const glm::dvec3 u(q[0], q[1], q[2]);
    return v + 2.0 * glm::cross(u, glm::cross(u, v) + q[3] * v);
}

std::vector<TrackedFrame> replayTracked(const std::string& recording, const std::string& scene, std::int64_t frames,
                                        const std::string& tag) {
    const fs::path root = sourceDir(), scratch = scratchDir("replay_tracking_" + tag);
    const std::string args = (root / recording).string() + " --scene " + (root / scene).string() +
                             " --pose tracking --no-video --no-compare --write-frames 0 --max-frames " +
                             std::to_string(frames) + " --out " + (scratch / "out").string();
    if (runLightskin(args, scratch, "tracking") != 0) {
        ADD_FAILURE() << "lightskin replay " << args << "\n" << test::readText(scratch / "tracking.stderr.txt");
        return {};
    }
    const nlohmann::json report = nlohmann::json::parse(test::readText(scratch / "out" / "report.json"));
    std::int64_t recorded = 0;
    const std::vector<TruthPose> truth = recordingTruth(root / recording, recorded);
    const tracking::TagWorld world = tracking::TagWorld::load(root / recording / "synth" / "tag-world.json");
    const double tangent = std::tan(kBudgetDegrees * 3.14159265358979323846 / 180.0);
    std::vector<TrackedFrame> out;
    for (const auto& f : report["frames"]) {
        const std::size_t i = f["index"].get<std::size_t>();
        TrackedFrame t;
        t.state = f["tracking"].get<std::string>();
        if (f["world_T_camera"].is_object() && i < truth.size()) {
            t.rotationErrorDegrees = rotationErrorDegrees(f["world_T_camera"], truth[i]);
            t.translationError = translationError(f["world_T_camera"], truth[i]);
            const glm::dvec3 trueCentre(truth[i].t[0], truth[i].t[1], truth[i].t[2]);
            glm::dvec3 d;
            for (glm::length_t k = 0; k < 3; ++k)
                d[k] = f["world_T_camera"]["translation"][std::size_t(k)].get<double>() - trueCentre[k];
            const glm::dvec3 view = rotate(truth[i].q, glm::dvec3(0.0, 0.0, 1.0));
            t.alongErrorMetres = glm::dot(d, view);
            t.acrossErrorMetres = glm::length(d - t.alongErrorMetres * view);
            double nearest = std::numeric_limits<double>::infinity();
            for (const tracking::WorldTag& worldTag : world.tags())
                nearest = std::min(nearest, glm::length(worldTag.world_T_tag.translation() - trueCentre));
            t.acrossBoundMetres = kSigmasOverBudgetSigmas * nearest * tangent;
            // The report's own pose error (replay compares with the recording's ground truth) must be
            // this test's, computed from frames.jsonl independently (1e-9 m; 1e-6 deg: acos near 0).
            EXPECT_NEAR(f["poseError"]["translationMetres"].get<double>(), t.translationError, 1e-9) << f.dump();
            EXPECT_NEAR(f["poseError"]["rotationDegrees"].get<double>(), t.rotationErrorDegrees, 1e-6) << f.dump();
        } else {
            EXPECT_FALSE(f.contains("poseError")) << "no pose, no pose error: " << f.dump();
            // No pose: nothing is placed, so GI is inactive and the report says why.
            EXPECT_FALSE(f["giActive"].get<bool>()) << f.dump();
            EXPECT_NE(f.value("giInactiveCause", std::string()).find("no camera pose"), std::string::npos) << f.dump();
        }
        std::printf("%s frame %zu: %s, pose error %.2f deg, %.3f m across (bound %.3f), %.3f m along the view\n",
                    tag.c_str(), i, t.state.c_str(), t.rotationErrorDegrees, t.acrossErrorMetres, t.acrossBoundMetres,
                    t.alongErrorMetres);
        out.push_back(t);
    }
    // The summary: the worst error of the tracking frames, as computed above.
    double worst = -1.0;
    for (const TrackedFrame& t : out)
        if (t.state == "tracking") worst = std::max(worst, t.translationError);
    if (worst >= 0.0) {
        EXPECT_NEAR(report["poseError"]["byState"]["tracking"]["translationMetres"]["max"].get<double>(), worst, 1e-9);
        EXPECT_NE(test::readText(scratch / "out" / "report.md").find("pose error, tracking frames"), std::string::npos);
    }
    return out;
}

/// Per frame of the recording: does the scene's detector decode a tag of the world other than `excludedId` (-1: any)?
std::vector<bool> decodedFrames(const std::string& recording, const std::string& scene, int excludedId) {
    const fs::path root = sourceDir();
    const nlohmann::json sceneJson = nlohmann::json::parse(test::readText(root / scene));
    tracking::DetectorSettings settings =
        tracking::detectorSettingsFromJson(sceneJson.at("tracking").at("detector").dump(), scene);
    tracking::TagDetector detector = tracking::TagDetector::create(settings);
    auto source = capture::openFrameSource((root / recording).string());
    RgbdFrame frame;
    std::vector<tracking::TagDetection> found;
    std::vector<bool> decoded;
    while (source->next(frame)) {
        detector.detectInto(frame.colour, found);
        decoded.push_back(std::any_of(found.begin(), found.end(),
                                      [excludedId](const tracking::TagDetection& d) { return d.id != excludedId; }));
    }
    return decoded;
}

/// The state the tracker must report: tracking where a usable tag is decoded, then held for
/// kMaxHeldFrames frames without one, then lost.
std::vector<std::string> expectedStates(const std::vector<bool>& decoded) {
    std::vector<std::string> states;
    int without = 0;
    for (const bool d : decoded) {
        without = d ? 0 : without + 1;
        states.push_back(without == 0 ? "tracking" : without <= kMaxHeldFrames ? "held" : "lost");
    }
    return states;
}

/// Checks a tracking frame against the budget; returns false (without failing) when only its
/// rotation exceeds it, so that the caller can compare such frames with its known findings.
bool expectWithinBudget(const TrackedFrame& f, std::size_t i) {
    EXPECT_GE(f.acrossErrorMetres, 0.0) << "frame " << i << ": tracking without a pose";
    EXPECT_LE(f.acrossErrorMetres, f.acrossBoundMetres) << "frame " << i;
    return f.rotationErrorDegrees <= kSigmasOverBudgetSigmas * kBudgetDegrees;
}

// All 40 frames of synth-orbit with orbit.json's tracking settings (quadDecimate 1, upsample 2).
// The wall tag (id 10) alone cannot place the table's board (its poses exceed maxWorldCornerStdPx,
// tests/tracking/SynthReplayTest.cpp): a frame tracks exactly when a board tag is decoded.
// Measured: board decoded in 34 frames; tracked 0.23-1.31 degrees (the larger ones the One-Euro
// filter's lag in the first frames), up to 0.066 m (frame 25, mostly along the view); frames 14,
// 16-18, 22 and 24 without tags. Before (native-size detection, every frame accepted): up to 0.66 m /
// 11 degrees at frame 22. orbit.json's roomModel tracks the frames without tags by depth against the room
// model (roommodel/): each is depth-tracked, or held where ICP is refused, and a depth-tracked frame meets the
// tracked frames' budget. Measured: 14, 16-18 and 22 depth-tracked (0.018-0.028 m, 0.76-0.86 deg; held they
// were 0.12-0.38 m, 4-12.7 deg), 24 held.
TEST(ReplayTracking, SynthOrbitTrackedPoseFollowsGroundTruth) {
    const auto expected = expectedStates(decodedFrames("recordings/synth-orbit", "recordings/scenes/orbit.json", 10));
    const auto frames = replayTracked("recordings/synth-orbit", "recordings/scenes/orbit.json", 40, "synth_orbit");
    ASSERT_EQ(frames.size(), 40u);
    ASSERT_EQ(expected.size(), 40u);
    std::vector<std::size_t> overRotationBudget;
    int depthTracked = 0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const bool byDepth = expected[i] == "held" && frames[i].state == "depth-tracked";
        depthTracked += byDepth ? 1 : 0;
        if (!byDepth) {
            EXPECT_EQ(frames[i].state, expected[i]) << "frame " << i;
        }
        if ((frames[i].state == "tracking" || byDepth) && !expectWithinBudget(frames[i], i))
            overRotationBudget.push_back(i);
    }
    EXPECT_EQ(overRotationBudget, std::vector<std::size_t>{}) << "tracked frames beyond 2.25 degrees";
    EXPECT_GT(depthTracked, 0) << "orbit.json's roomModel must track some frames without tags";
    EXPECT_GT(std::count(expected.begin(), expected.end(), "tracking"), 0) << "the recording must exercise tracking";
}

// synth-pan, all 40 frames: the tag board leaves the view and comes back. A frame tracks exactly
// when a tag is decoded (pan.json: quadDecimate 1); held for kMaxHeldFrames frames after the last
// one, then lost without a pose. Measured: tags decoded in frames 0-12 and 28-39 (tracked to
// <= 0.005 m across the view, 0.04-3.16 deg; the old bounds 0.025 m / 5 deg were fitted to that
// run); held 13-22, lost 23-27.
TEST(ReplayTracking, SynthPanLosesTheTagAndReacquiresIt) {
    const auto expected = expectedStates(decodedFrames("recordings/synth-pan", "recordings/scenes/pan.json", -1));
    const auto frames = replayTracked("recordings/synth-pan", "recordings/scenes/pan.json", 40, "synth_pan");
    ASSERT_EQ(frames.size(), 40u);
    ASSERT_EQ(expected.size(), 40u);
    std::vector<std::size_t> overRotationBudget;
    for (std::size_t i = 0; i < frames.size(); ++i) {
        EXPECT_EQ(frames[i].state, expected[i]) << "frame " << i;
        if (frames[i].state == "tracking" && !expectWithinBudget(frames[i], i)) overRotationBudget.push_back(i);
        if (frames[i].state == "lost") {
            EXPECT_LT(frames[i].acrossErrorMetres, 0.0) << "a lost frame has no pose, frame " << i;
        }
    }
    // Known finding, not re-fitted: the filtered pose breaks the rotation
    // budget in frame 29 (3.16 degrees > 2.25), the second frame after re-acquisition while the
    // camera pans: the One-Euro filter restarted at frame 28 and lags (the unfiltered measurement is
    // within 0.74 degrees in every frame, tests/tracking/SynthReplayTest.cpp). Listed exactly, so
    // that any other frame beyond the budget fails, and so does a fix (then empty the list).
    EXPECT_EQ(overRotationBudget, std::vector<std::size_t>{29}) << "tracked frames beyond 2.25 degrees";
    // The recording must exercise every state, or the expectations above prove little.
    for (const char* state : {"tracking", "held", "lost"})
        EXPECT_GT(std::count(expected.begin(), expected.end(), state), 0) << state;
}

// The real Kinect v1 .oni (unregistered depth, registered in software) has VALs and
// visible GI on every one of its 12 frames, with the oni_room.json scene (objects on its floor).
TEST(ReplayRealData, OniKinectV1HasValsAndVisibleGiOnEveryFrame) {
    const fs::path root = sourceDir(), scratch = scratchDir("replay_oni_every_frame");
    const std::string common = (root / "tests/data/oni-kinect-v1/3dj_test.oni").string() + " --scene " +
                               (root / "recordings/scenes/oni_room.json").string() +
                               // The differential darkens the floor at the objects' contact (by design), which
                               // the soft edge band blends into the with-GI half only: off, as in the goldens.
                               " --pose fixed --no-video --differential off";
    ASSERT_EQ(runLightskin(common + " --out " + (scratch / "final").string(), scratch, "final"), 0)
        << test::readText(scratch / "final.stderr.txt");
    ASSERT_EQ(runLightskin(common + " --no-compare --view normals --out " + (scratch / "normals").string(), scratch,
                           "normals"),
              0)
        << test::readText(scratch / "normals.stderr.txt");
    const nlohmann::json report = nlohmann::json::parse(test::readText(scratch / "final" / "report.json"));
    ASSERT_EQ(report["frames"].size(), 12u);
    EXPECT_EQ(report["giActiveFrames"].get<int>(), 12);
    EXPECT_EQ(report["giInactiveFrames"].get<int>(), 0);
    // On the default backend, as the main job runs it (gi.backend "auto": the CPU on llvmpipe).
    EXPECT_NE(test::readText(scratch / "final.stdout.txt")
                  .find("GI (" + report["technique"].get<std::string>() + ") active in all 12 frames"),
              std::string::npos);
    EXPECT_EQ(report["technique"].get<std::string>().rfind("lightskin", 0), 0u) << report["technique"];
    for (const auto& f : report["frames"]) {
        // VALs: stride 8 over 640x480 gives 80 x 60 = 4800 VAL cells; the registered depth covers
        // > 40% of the image (tests/capture OniSourceTest), so a frame should have ~1900 VALs; 960
        // (20%) leaves half of that for cells whose samples are all holes or edges. 0 = the bug.
        EXPECT_GT(f["vals"].get<int>(), 960) << f.dump();
        EXPECT_TRUE(f["giActive"].get<bool>()) << f.dump();
        EXPECT_FALSE(f.contains("giInactiveCause")) << f.dump();
    }
    // Visible GI: the with-GI and without-GI halves of each comparison image differ over the virtual
    // content. Without GI (before registration) they were bit-identical, and the renderer is
    // deterministic up to one 8-bit step now and then (docs/TESTING.md), so the noise floor is 1
    // step. Required: at least half of the virtual pixels change by >= 3 sRGB steps (3x that floor) in
    // some channel, and GI only adds light (the indirect term is >= 0), so the mean of with - without
    // must be > 0 in linear luminance and no pixel may get darker by more than the 1-step noise.
    for (int index = 0; index < 12; ++index) {
        SCOPED_TRACE("frame " + std::to_string(index));
        const cv::Mat mask = virtualMask(scratch / "final" / "frames" / frameFile(index),
                                         scratch / "normals" / "frames" / frameFile(index));
        ASSERT_GT(cv::countNonZero(mask), 4000); // measured ~6300 virtual pixels per frame
        const cv::Mat compare =
            cv::imread((scratch / "final" / "compare" / frameFile(index)).string(), cv::IMREAD_COLOR);
        ASSERT_EQ(compare.cols, 2 * mask.cols);
        const cv::Mat with = compare(cv::Rect(0, 0, mask.cols, mask.rows)),
                      without = compare(cv::Rect(mask.cols, 0, mask.cols, mask.rows));
        int changed = 0, darker = 0;
        double sumDifference = 0.0;
        for (int v = 0; v < mask.rows; ++v)
            for (int u = 0; u < mask.cols; ++u) {
                if (!mask.at<std::uint8_t>(v, u)) continue;
                const cv::Vec3b a = with.at<cv::Vec3b>(v, u), b = without.at<cv::Vec3b>(v, u);
                int most = 0, least = 0;
                for (int c = 0; c < 3; ++c) {
                    most = std::max(most, int(a[c]) - int(b[c]));
                    least = std::min(least, int(a[c]) - int(b[c]));
                }
                changed += std::max(most, -least) >= 3 ? 1 : 0;
                darker += least < -1 ? 1 : 0;
                const auto luminance = [](const cv::Vec3b& p) {
                    return 0.0722 * double(eval::srgbToLinear(p[0] / 255.0f)) +
                           0.7152 * double(eval::srgbToLinear(p[1] / 255.0f)) +
                           0.2126 * double(eval::srgbToLinear(p[2] / 255.0f));
                };
                sumDifference += luminance(a) - luminance(b);
            }
        const int pixels = cv::countNonZero(mask);
        std::printf(
            "oni frame %d: %d of %d virtual pixels changed by >= 3 steps, %d darker, mean linear luminance +%.4f\n",
            index, changed, pixels, darker, sumDifference / pixels);
        EXPECT_GE(2 * changed, pixels) << "GI is not visible on the virtual objects";
        EXPECT_GT(sumDifference, 0.0);
        EXPECT_EQ(darker, 0);
    }
}

// When GI does nothing the console, report.json and report.md say so per frame and in the
// summary, with the cause. The .oni with --raw-depth (no software registration): no VALs.
TEST(ReplayGiActive, UnregisteredDepthIsReportedAsGiInactive) {
    const fs::path root = sourceDir(), scratch = scratchDir("replay_gi_inactive");
    const std::string args = (root / "tests/data/oni-kinect-v1/3dj_test.oni").string() + " --scene " +
                             (root / "recordings/scenes/oni_room.json").string() +
                             " --pose fixed --no-video --no-compare --raw-depth" + " --max-frames 2 --write-frames 0 --out " +
                             (scratch / "out").string();
    ASSERT_EQ(runLightskin(args, scratch, "raw"), 0) << test::readText(scratch / "raw.stderr.txt");
    const nlohmann::json report = nlohmann::json::parse(test::readText(scratch / "out" / "report.json"));
    const std::string cause = "depth is not registered to colour: no VALs";
    ASSERT_EQ(report["frames"].size(), 2u);
    for (const auto& f : report["frames"]) {
        EXPECT_EQ(f["vals"].get<int>(), 0) << f.dump();
        EXPECT_FALSE(f["giActive"].get<bool>()) << f.dump();
        EXPECT_EQ(f.value("giInactiveCause", std::string()), cause) << f.dump();
    }
    EXPECT_EQ(report["giActiveFrames"].get<int>(), 0);
    EXPECT_EQ(report["giInactiveFrames"].get<int>(), 2);
    EXPECT_EQ(report["giInactiveCauses"][cause].get<int>(), 2);
    const std::string md = test::readText(scratch / "out" / "report.md");
    EXPECT_NE(md.find("| GI active | 0 of 2 frames; **inactive in 2**: " + cause), std::string::npos) << md;
    EXPECT_NE(md.find("| inactive: " + cause + " |"), std::string::npos) << md;
    const std::string err = test::readText(scratch / "raw.stderr.txt"),
                      out = test::readText(scratch / "raw.stdout.txt");
    EXPECT_NE(err.find("frame 0: GI inactive: " + cause), std::string::npos) << err;
    EXPECT_NE(err.find("frame 1: GI inactive: " + cause), std::string::npos) << err;
    EXPECT_NE(out.find("GI INACTIVE in 2 of 2 frames"), std::string::npos) << out;
}

// A scene without a GI technique: inactive, with that cause, so that a reader can tell "no GI" from
// "GI that happens to be dark".
TEST(ReplayGiActive, SceneWithoutTechniqueIsReportedAsGiInactive) {
    const fs::path root = sourceDir(), scratch = scratchDir("replay_gi_none");
    const std::string args = (root / "recordings/synth-clean-channels").string() + " --scene " +
                             (root / "recordings/scenes/cube_no_gi.json").string() + " --pose ground-truth --no-video" +
                             " --max-frames 1 --write-frames 0 --out " + (scratch / "out").string();
    ASSERT_EQ(runLightskin(args, scratch, "none"), 0) << test::readText(scratch / "none.stderr.txt");
    const nlohmann::json report = nlohmann::json::parse(test::readText(scratch / "out" / "report.json"));
    ASSERT_EQ(report["frames"].size(), 1u);
    EXPECT_FALSE(report["frames"][0]["giActive"].get<bool>());
    EXPECT_NE(report["frames"][0].value("giInactiveCause", std::string()).find("technique is \"none\""),
              std::string::npos)
        << report["frames"][0].dump();
    EXPECT_EQ(report["giInactiveFrames"].get<int>(), 1);
}

} // namespace
} // namespace lightskin::test
