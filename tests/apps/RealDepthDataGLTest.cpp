// The targets for the indirect light on real depth, on the bundled real recordings: a bunny
// and a cube placed on real surfaces (as `lightskin bench-realdepth` places them: the plane fitted to
// frame 0's depth around an anchor pixel, resting on it or sunk into it), every frame through the
// production per-frame pipeline (mr::FramePipeline, default = robust light model) with the brute
// force on the same VALs. Targets: speckle (eval::measureSpeckle on smooth surface patches, as in the
// bench) below 0.5 % for both, and no black or blown pixel inside the lit objects.
//
// Thresholds: 0.5 % and "zero black/blown" are the targets, not measured values. A black
// pixel (Y < 0.1 x its 5x5 median in a lit neighbourhood) or a blown one (> 10x) is a defect of the
// light model wherever the truth is smooth (the smooth-patch mask keeps creases and occlusion edges
// out), so any count above 0 fails. The speckle fraction of a smooth indirect image is 0; 0.5 % allows
// the few pixels where the smooth-patch mask keeps a steep but true falloff (receivers turning away
// from the room within 2 px, docs/BENCHMARKS.md). Where a case does not meet a target yet, the case
// says which and why (measured in docs/BENCHMARKS.md), and asserts the rest.
#include "GlTestEnvironment.h"
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/eval/Speckle.h>
#include <lightskin/mr/FramePipeline.h>
#include <lightskin/render/Scene.h>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <string>
#include <vector>

using namespace lightskin;

namespace {

/// Unit normal (facing the camera) and a point of the plane through frame 0's depth in a 31x31 window:
/// points within `depthWindow` of the anchor's depth (the anchor pixel's, or where it has none the
/// median of its 5x5 window, as the bench).
std::pair<glm::dvec3, glm::dvec3> fitPlane(const RgbdFrame& frame, int u0, int v0, double depthWindow) {
    std::vector<cv::Vec3d> points;
    const auto depthAt = [&](int u, int v) {
        return double(frame.depth.at<std::uint16_t>(v, u)) * frame.depthScaleMetres;
    };
    std::vector<double> near;
    for (int v = v0 - 2; v <= v0 + 2; ++v)
        for (int u = u0 - 2; u <= u0 + 2; ++u)
            if (depthAt(u, v) > 0.0) near.push_back(depthAt(u, v));
    EXPECT_GE(near.size(), 5u) << "anchor (" << u0 << ", " << v0 << ") has almost no depth around it";
    if (near.empty()) return {};
    std::nth_element(near.begin(), near.begin() + std::ptrdiff_t(near.size() / 2), near.end());
    const double z0 = depthAt(u0, v0) > 0.0 ? depthAt(u0, v0) : near[near.size() / 2];
    for (int v = v0 - 15; v <= v0 + 15; ++v)
        for (int u = u0 - 15; u <= u0 + 15; ++u) {
            const double z = depthAt(u, v);
            if (z > 0.0 && std::abs(z - z0) < depthWindow) {
                const glm::dvec3 p = frame.depthIntrinsics.backProject(u, v, z);
                points.emplace_back(p.x, p.y, p.z);
            }
        }
    EXPECT_GT(points.size(), 100u) << "anchor (" << u0 << ", " << v0 << ") is not on a surface with depth";
    const cv::PCA pca(cv::Mat(int(points.size()), 3, CV_64F, points.data()), cv::noArray(), cv::PCA::DATA_AS_ROW);
    glm::dvec3 n(pca.eigenvectors.at<double>(2, 0), pca.eigenvectors.at<double>(2, 1),
                 pca.eigenvectors.at<double>(2, 2));
    const glm::dvec3 mean(pca.mean.at<double>(0), pca.mean.at<double>(1), pca.mean.at<double>(2));
    if (glm::dot(n, mean) > 0.0) n = -n;
    glm::dvec3 p = frame.depthIntrinsics.backProject(u0, v0, z0);
    p -= glm::dot(p - mean, n) * n;
    return {glm::normalize(n), p};
}

struct RealCase {
    const char* name;
    const char* folder; ///< in tests/data
    mr::PoseMode pose;
    int anchors[2][2]; ///< frame 0 pixels of the surfaces under the bunny and the cube (the bench's)
    double sinkMetres;
    int frames;
    /// false where the speckle target is not met yet (see the case list): then only black/blown
    /// pixels, coverage and light are asserted for that technique.
    bool lightSkinSpeckleTarget, bruteForceSpeckleTarget, bruteForceBlackTarget;
    bool lightSkinBlownTarget = true;
    double fitDepthWindow = 0.03; ///< the bench's: 15 cm for the .oni's floor seen at a grazing angle
    /// Both techniques also meet the speckle target by the issue's own definition (the median test alone,
    /// before the smooth-profile refinement, eval::measureSpeckle's smoothProfiles = false). The
    /// refinement only excuses steep true falloffs at the mesh's own scale, which the objects at 1-2 m in
    /// ICL-NUIM and 2.2 m in the .oni do not need; the threshold stays the 0.5 %.
    bool medianOnlyTarget = false;
    /// false where LightSkin has a black front-face pixel (none left).
    bool lightSkinBlackTarget = true;
    /// The bunny stands near enough that its inside shows through its scan holes (back faces in the G-buffer).
    bool backFaces = false;
};

void PrintTo(const RealCase& c, std::ostream* os) { *os << c.name; }

class RealDepthDataGLTest : public test::GlTest, public ::testing::WithParamInterface<RealCase> {};

TEST_P(RealDepthDataGLTest, ObjectsOnRealSurfacesMeetTheSpeckleTargets) {
    const RealCase& c = GetParam();
    const std::string recording = test::dataPath(c.folder).string();
    render::Scene scene = render::loadScene(test::sourceDir() / "recordings" / "scenes" / "on_real_surface.json");
    ASSERT_EQ(scene.objects.size(), 2u);
    ASSERT_TRUE(scene.gi.robustRealDepth); // the default light model
    auto source = capture::openFrameSource(recording, {});
    RgbdFrame first;
    ASSERT_TRUE(source->next(first));
    ASSERT_EQ(first.depth.type(), CV_16UC1);
    Pose world_T_camera; // PoseMode::Fixed: the world is frame 0's camera
    if (c.pose == mr::PoseMode::GroundTruth) {
        ASSERT_TRUE(first.groundTruth_world_T_camera.has_value());
        world_T_camera = *first.groundTruth_world_T_camera;
    }
    // Model bases (min y, centred in x and z), read off the mesh files: bun_zipper_res4 x -0.09315..0.05816,
    // y from 0.03362, z -0.05664..0.05780 (scale 1.5); cube.obj [-0.5, 0.5]^3 (scale 0.12).
    const glm::vec3 bases[2] = {{-0.01749f, 0.03362f, 0.00058f}, {0.0f, -0.5f, 0.0f}};
    const float scales[2] = {1.5f, 0.12f};
    glm::dvec3 bunnyPoint{0.0}, bunnyNormal{0.0};
    for (int i = 0; i < 2; ++i) {
        const auto [nCamera, pCamera] = fitPlane(first, c.anchors[i][0], c.anchors[i][1], c.fitDepthWindow);
        const glm::dvec3 n = glm::normalize(world_T_camera.rotation() * nCamera),
                         surface = world_T_camera.transformPoint(pCamera), p = surface - c.sinkMetres * n;
        const glm::quat q(glm::vec3(0.0f, 1.0f, 0.0f), glm::vec3(n));
        scene.objects[std::size_t(i)].world_T_model =
            glm::translate(glm::mat4(1.0f), glm::vec3(p)) * glm::mat4_cast(q) *
            glm::scale(glm::mat4(1.0f), glm::vec3(scales[i])) * glm::translate(glm::mat4(1.0f), -bases[i]);
        if (i == 0) { // the light is placed from the surface point, sunk or not (as the bench)
            bunnyPoint = surface;
            bunnyNormal = n;
        }
    }
    const glm::dvec3 towardCamera = glm::normalize(world_T_camera.translation() - bunnyPoint);
    scene.lights[0].position = glm::vec3(bunnyPoint + 0.8 * bunnyNormal + 0.3 * towardCamera); // as the bench

    source = capture::openFrameSource(recording, {});
    mr::PipelineOptions options;
    options.poseMode = c.pose;
    options.compare = false;
    options.referenceIndirect = true;
    options.backend = gi::BackendSetting::Gl; // as the bench, whose measurements (docs/BENCHMARKS.md) the cases cite
    auto pipeline = mr::FramePipeline::create(scene, source->info(), options);
    RgbdFrame frame;
    mr::FrameOutput out;
    cv::Mat smooth;
    int frames = 0, backFacePixels = 0;
    while (frames < c.frames && source->next(frame)) {
        pipeline->process(frame, out);
        ASSERT_GT(out.valCount, 1000u);
        ASSERT_FALSE(out.linearIndirect.empty());
        ASSERT_FALSE(out.linearIndirectReference.empty());
        // 30 degrees, 2 %: the bench's smooth-patch restriction (bench/src/RealDepthBench.cpp).
        eval::smoothSurfaceMaskInto(out.coverage, out.virtualNormals, out.virtualDepthMetres, 30.0, 0.02, smooth);
        // ... counting only pixels the composite shows (eval/Speckle.h, "What the user sees"), as the bench.
        cv::bitwise_and(smooth, out.visibleCoverage, smooth);
        ASSERT_EQ(out.backFacing.size(), out.coverage.size());
        backFacePixels += cv::countNonZero(out.backFacing);
        for (const bool lightSkin : {true, false}) {
            const cv::Mat& image = lightSkin ? out.linearIndirect : out.linearIndirectReference;
            // Back faces (the bunny's inside through its scan holes) are dark in both techniques and
            // leave the measure (eval/Speckle.h); every front-face pixel is measured.
            const eval::SpeckleStats s =
                eval::measureSpeckle(image, out.coverage, nullptr, smooth, true, out.backFacing);
            SCOPED_TRACE(std::string(lightSkin ? "LightSkin" : "brute force") + ", frame " +
                         std::to_string(frame.index) + ": " + s.describe());
            EXPECT_GT(s.interiorPixels, 1000u); // the objects are in view and mostly smooth
            EXPECT_GT(s.meanLuminance, 0.0);    // lit: not an all-zero image
            if (lightSkin ? c.lightSkinSpeckleTarget : c.bruteForceSpeckleTarget) {
                EXPECT_LT(s.speckleFraction(), 0.005);
            }
            if (lightSkin ? c.lightSkinBlackTarget : c.bruteForceBlackTarget) {
                EXPECT_EQ(s.blackPixels, 0u);
            }
            if (!lightSkin || c.lightSkinBlownTarget) {
                EXPECT_EQ(s.blownPixels, 0u);
            }
            if (c.medianOnlyTarget) {
                const eval::SpeckleStats m =
                    eval::measureSpeckle(image, out.coverage, nullptr, smooth, false, out.backFacing);
                EXPECT_LT(m.speckleFraction(), 0.005) << "median-only definition: " << m.describe();
            }
            for (int v = 0; v < image.rows; ++v) // gi::GBufferView::worldNormal: 0 on back faces
                for (int u = 0; u < image.cols; ++u) {
                    if (out.backFacing.at<std::uint8_t>(v, u)) {
                        ASSERT_EQ(image.at<cv::Vec3f>(v, u), cv::Vec3f(0.0f, 0.0f, 0.0f)) << u << ", " << v;
                    }
                }
            // The measure still finds a front-face pixel turned black beside a back face: the first lit
            // measured pixel with a back face in its 5x5 window (else the first lit measured pixel), set to 0.
            if (lightSkin ? c.lightSkinBlackTarget : c.bruteForceBlackTarget) {
                cv::Mat measured, injectedMap, injected = image.clone();
                eval::measureSpeckle(image, out.coverage, &measured, smooth, true, out.backFacing);
                cv::Point target(-1, -1), fallback(-1, -1);
                for (int v = 2; v + 2 < image.rows && target.x < 0; ++v)
                    for (int u = 2; u + 2 < image.cols && target.x < 0; ++u) {
                        const cv::Vec3f p = image.at<cv::Vec3f>(v, u);
                        const double y = 0.2126 * double(p[2]) + 0.7152 * double(p[1]) + 0.0722 * double(p[0]);
                        if (measured.at<std::uint8_t>(v, u) != 64 || y < 0.5 * s.meanLuminance) continue;
                        if (fallback.x < 0) fallback = {u, v};
                        if (cv::countNonZero(out.backFacing(cv::Rect(u - 2, v - 2, 5, 5))) > 0) target = {u, v};
                    }
                if (target.x < 0) target = fallback;
                ASSERT_GE(target.x, 0);
                injected.at<cv::Vec3f>(target) = cv::Vec3f(0.0f, 0.0f, 0.0f);
                const eval::SpeckleStats i =
                    eval::measureSpeckle(injected, out.coverage, &injectedMap, smooth, true, out.backFacing);
                EXPECT_EQ(injectedMap.at<std::uint8_t>(target), 255) << "a black front-face pixel at " << target;
                EXPECT_GT(i.blackPixels, s.blackPixels) << "a black front-face pixel at " << target;
            }
        }
        ++frames;
    }
    EXPECT_EQ(frames, c.frames);
    if (c.backFaces) {
        EXPECT_GT(backFacePixels, 0); // the bunny's scan holes are in view: the mask is exercised
    }
}

// Frames: all of TUM fr2 (2), the PCL TIFF (1) and TUM fr3 (1); 3 of ICL-NUIM's 5 (moving camera), 3
// of the .oni's 11 (camera at rest).
// TUM fr2 runs sunk only (resting measures the same or lower in the bench), to keep the suite short.
// Fields: name, folder, pose, anchors, sink, frames, LightSkin speckle target, brute-force speckle
// target, brute-force black-pixel target, LightSkin blown target, plane-fit window, median-only target,
// LightSkin black-pixel target, back faces in view.
// clang-format off
INSTANTIATE_TEST_SUITE_P(BundledRecordings, RealDepthDataGLTest, ::testing::Values(
    RealCase{"icl_nuim", "icl-nuim-open3d", mr::PoseMode::GroundTruth, {{250, 390}, {460, 430}}, 0.0, 3, true, true, true, true, 0.03, true},
    // Sunk 1 cm: the cube's sparse points under the floor darkened its contact band (0.52 % LightSkin by
    // the median-only definition before guards G10 and G11); G11 leaves them out of eq. 12-13.
    RealCase{"icl_nuim_sunk_1cm", "icl-nuim-open3d", mr::PoseMode::GroundTruth, {{250, 390}, {460, 430}}, 0.01, 3, true, true, true, true, 0.03, true},
    // Back faces through the scan holes: the bunny (bun_zipper_res4.ply, 21 open boundaries) stands near enough
    // on TUM fr2 (1.1 m) and the PCL TIFF (0.65 m) that its inside shows through them. Both techniques write 0
    // there (the inside of a nearly closed object is lit only through its holes: gi_back_face_hole_gl_test) and
    // the measure leaves them out (eval/Speckle.h); before, LightSkin gave them 0 and the brute force the light of
    // the turned normal, and they counted as LightSkin's black pixels. Its other black pixels here, 2-3 per case at
    // the holes' rims, were front faces: a back-facing fold within the shade pass's position tolerance overwrote
    // them (gather_shade.frag keeps front-facing fragments only now; docs/BENCHMARKS.md, "Back faces through scan
    // holes"). So LightSkin's black-pixel target holds without exception. TUM fr2 sunk: the brute force's black
    // pixel (281,384) is the true light, not a defect: the bunny's underside at its contact line, below the
    // measured desk in front of it (the VALs there face away from it), where the Embree truth with visibility is
    // as dark (0.0041 against the brute force's 0.0049 and 0.17-0.24 one row up); the composite's soft occlusion
    // band shows it (docs/bench/history/real-depth.md, "The brute force's black pixel at the contact").
    RealCase{"tum_fr2_desk_sunk_1cm", "tum-fr2-desk", mr::PoseMode::Fixed, {{300, 365}, {150, 335}}, 0.01, 2, true, true, false, true, 0.03, false, true, true},
    RealCase{"pcl_kinect_tiff", "pcl-kinect-tiff", mr::PoseMode::Fixed, {{250, 380}, {520, 380}}, 0.0, 1, true, true, true, true, 0.03, false, true, true},
    // Sunk 1 cm: the brute force's black pixel on the bunny's upper side was the mesh's, not the light's:
    // a triangle listed twice in bun_zipper_res4.ply, the copy wound the other way, had turned the
    // generated normals there by up to ~170 degrees; the loader drops such copies now
    // (render_mesh_normals_gl_test). Back faces: see above.
    RealCase{"pcl_kinect_tiff_sunk_1cm", "pcl-kinect-tiff", mr::PoseMode::Fixed, {{250, 380}, {520, 380}}, 0.01, 1, true, true, true, true, 0.03, false, true, true},
    // fr3: the objects stand ~2 m from the camera (~1800 measured pixels, a 5x5 window spans ~2 cm of the bunny).
    // The brute force's 0.77 % speckle there was the shading normals' kinks under grazing light (docs/BENCHMARKS.md,
    // "TUM fr3"): the loader gave each shared vertex of the PLY one face's normal; with smooth normals it meets
    // the target (0.25 %), so no exception is left.
    RealCase{"tum_fr3_office", "tum-fr3-office", mr::PoseMode::Fixed, {{300, 440}, {580, 420}}, 0.0, 1, true, true, true},
    // The real Kinect v1 .oni (depth registered in software), objects on the floor ~2.2 m away: 3 of its 11 frames.
    RealCase{"oni_kinect_v1", "oni-kinect-v1/3dj_test.oni", mr::PoseMode::Fixed, {{330, 440}, {250, 445}}, 0.0, 3, true, true, true, true, 0.15, true},
    // The same sunk 1 cm into the floor (sparse points under real Kinect v1 depth: guard G11).
    RealCase{"oni_kinect_v1_sunk_1cm", "oni-kinect-v1/3dj_test.oni", mr::PoseMode::Fixed, {{330, 440}, {250, 445}}, 0.01, 3, true, true, true, true, 0.15, true}),
    [](const ::testing::TestParamInfo<RealCase>& p) { return std::string(p.param.name); });
// clang-format on

} // namespace
