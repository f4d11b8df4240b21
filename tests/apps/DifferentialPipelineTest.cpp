// Differential rendering in the per-frame pipeline (compositing.differential): a small virtual cube
// 16 cm in front of a real grey wall, lit by an in-room point light, pose "fixed" (world = camera
// frame: x right, y down, z forward). The receivers' numbers are checked against references in
// tests/gi/differential/DifferentialIrradianceTest.cpp; here: the pipeline darkens the wall in the cube's
// shadow, leaves pixels beyond the stated region bit for bit, writes no NaN/inf, and with the
// differential off (scene key or live option) gives exactly today's image.
#include "GlTestEnvironment.h"
#include "TestPaths.h"

#include <lightskin/mr/FramePipeline.h>
#include <lightskin/render/Scene.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <string>

using namespace lightskin;

namespace {

constexpr int kWidth = 320, kHeight = 240;
constexpr double kFocal = 300.0, kWall = 1.5; // pixels; metres (camera z of the wall)
const glm::dvec3 kCubeCentre(0.0, 0.0, 1.3);  // half size 0.04, 16 cm in front of the wall
constexpr double kHalf = 0.04;
const glm::dvec3 kLight(0.25, -0.25, 1.0);

std::string sceneText(bool differential) {
    return std::string(R"({"version": 1,
      "objects": [{"name": "cube", "mesh": "meshes/cube.obj", "transform": {"translation": [0.0, 0.0, 1.3], "scale": 0.08},
                   "material": {"diffuseAlbedo": 0.6, "specularAlbedo": 0.0}}],
      "lights": [{"type": "point", "position": [0.25, -0.25, 1.0], "power": 20}],
      "gi": {"technique": "none"},
      "compositing": {"differential": )") +
           (differential ? "true" : "false") + "}}";
}

struct PipelineRun {
    mr::FrameOutput out;
    cv::Mat camera;
};

PipelineRun runFrame(bool sceneDifferential, bool optionDifferential, mr::Overlay overlay = mr::Overlay::None) {
    const render::Scene scene = render::parseScene(sceneText(sceneDifferential),
                                                   test::sourceDir() / "recordings" / "scenes", "differential-test");
    capture::FrameSourceInfo info;
    info.kind = "test";
    info.uri = "differential-test";
    info.colourIntrinsics =
        CameraIntrinsics{.width = kWidth, .height = kHeight, .fx = kFocal, .fy = kFocal, .cx = 159.5, .cy = 119.5};
    info.depthIntrinsics = info.colourIntrinsics;
    mr::PipelineOptions options;
    options.poseMode = mr::PoseMode::Fixed;
    options.compare = false;
    options.linearComposite = true;
    options.differential = optionDifferential;
    options.overlay = overlay;
    auto pipeline = mr::FramePipeline::create(scene, info, options);
    RgbdFrame frame;
    frame.colour = cv::Mat(kHeight, kWidth, CV_8UC3, cv::Scalar::all(150));
    frame.depth = cv::Mat(kHeight, kWidth, CV_16UC1, cv::Scalar::all(1500)); // the wall, millimetres
    frame.depthScaleMetres = 0.001;
    frame.colourIntrinsics = frame.depthIntrinsics = info.colourIntrinsics;
    PipelineRun run;
    pipeline->process(frame, run.out);
    run.camera = frame.colour;
    return run;
}

glm::dvec3 wallPoint(int u, int v) { return {(u - 159.5) / kFocal * kWall, (v - 119.5) / kFocal * kWall, kWall}; }

// Slab test of the open segment a-b against the cube grown by `margin` (independent of Embree).
bool segmentHitsCube(const glm::dvec3& a, const glm::dvec3& b, double margin) {
    double t0 = 1e-6, t1 = 1.0 - 1e-6;
    for (int axis = 0; axis < 3; ++axis) {
        const double lo = kCubeCentre[axis] - kHalf - margin, hi = kCubeCentre[axis] + kHalf + margin,
                     d = b[axis] - a[axis];
        double ta = (lo - a[axis]) / d, tb = (hi - a[axis]) / d;
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
    }
    return t0 <= t1;
}

bool nearCubeInImage(int u, int v) {
    return std::abs(u - 159.5) < 15 && std::abs(v - 119.5) < 15;
} // projection +- 9.6 px

double decode(std::uint8_t value) {
    const double c = value / 255.0;
    return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

class DifferentialPipeline : public test::GlTest {};

TEST_F(DifferentialPipeline, ShadowsTheWallLeavesFarPixelsAndHasNoNonFiniteValues) {
    const PipelineRun on = runFrame(true, true);
    EXPECT_GT(on.out.differentialReceivers, 0);
    EXPECT_GT(on.out.differentialPixels, 0);
    EXPECT_EQ(on.out.linearNanPixels, 0);
    EXPECT_EQ(on.out.linearInfPixels, 0);
    ASSERT_TRUE(cv::checkRange(on.out.linearWithGi));

    // Region (gi/DifferentialIrradiance.h): bounding sphere r = 0.04 sqrt(3), R = r sqrt(1/0.01 - 1),
    // plus the shadow cone; receivers every 4 px stand for pixels up to 4 px (4 * 1.5 / 300 m) away.
    const double sphere = kHalf * std::sqrt(3.0), region = sphere * std::sqrt(99.0),
                 pixelMargin = 2.0 * 4.0 * kWall / kFocal;
    int far = 0, umbra = 0;
    for (int v = 0; v < kHeight; ++v)
        for (int u = 0; u < kWidth; ++u) {
            if (nearCubeInImage(u, v)) continue;
            const glm::dvec3 p = wallPoint(u, v);
            const cv::Vec3b in = on.camera.at<cv::Vec3b>(v, u), out = on.out.withGi.at<cv::Vec3b>(v, u);
            const bool nearSphere = glm::length(p - kCubeCentre) <= region + pixelMargin;
            if (!nearSphere && !segmentHitsCube(p, kLight, sphere + pixelMargin)) {
                ASSERT_EQ(out, in) << "pixel " << u << ", " << v << " beyond the region changed";
                ++far;
            }
            // Umbra (1 cm inside the shadow): the wall there gets only the cube's weak bounce instead
            // of the light (the wall's own VALs lie in its plane and add nothing), so it loses most
            // of its light; the exact ratio is tested on the receivers (DifferentialIrradianceTest).
            if (segmentHitsCube(p, kLight, -0.01)) {
                EXPECT_LT(decode(out[1]), 0.5 * decode(in[1]))
                    << "pixel " << u << ", " << v << " in the umbra is not dark";
                ++umbra;
            }
        }
    EXPECT_GT(far, 1000);
    EXPECT_GT(umbra, 20);
}

TEST_F(DifferentialPipeline, OffRestoresTodaysImageBitForBit) {
    const PipelineRun sceneOff = runFrame(false, true), optionOff = runFrame(true, false), on = runFrame(true, true);
    EXPECT_EQ(sceneOff.out.differentialReceivers, -1);
    EXPECT_EQ(optionOff.out.differentialReceivers, -1);
    EXPECT_EQ(cv::norm(sceneOff.out.withGi, optionOff.out.withGi, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(sceneOff.out.linearWithGi, optionOff.out.linearWithGi, cv::NORM_INF), 0.0);
    // Today's composite: the camera image wherever no virtual content covers the pixel.
    int changedByDifferential = 0;
    for (int v = 0; v < kHeight; ++v)
        for (int u = 0; u < kWidth; ++u) {
            if (nearCubeInImage(u, v)) continue;
            ASSERT_EQ(optionOff.out.withGi.at<cv::Vec3b>(v, u), optionOff.camera.at<cv::Vec3b>(v, u));
            if (on.out.withGi.at<cv::Vec3b>(v, u) != on.camera.at<cv::Vec3b>(v, u)) ++changedByDifferential;
        }
    EXPECT_GT(changedByDifferential, 50) << "the differential must change the real pixels around the cube";
}

TEST_F(DifferentialPipeline, DebugViewShowsTheShadowBlueAndDimsTheRest) {
    render::DebugView view = render::DebugView::Final;
    mr::Overlay overlay = mr::Overlay::None;
    mr::parseView("differential", view, overlay);
    ASSERT_EQ(overlay, mr::Overlay::Differential);
    const PipelineRun run = runFrame(true, true, overlay);
    int umbra = 0;
    for (int v = 0; v < kHeight; ++v)
        for (int u = 0; u < kWidth; ++u) {
            const cv::Vec3b shown = run.out.withGi.at<cv::Vec3b>(v, u), camera = run.camera.at<cv::Vec3b>(v, u);
            const glm::dvec3 p = wallPoint(u, v);
            if (!nearCubeInImage(u, v) && segmentHitsCube(p, kLight, -0.01)) {
                // dE / E_without < -0.5 there (the umbra keeps less than half its light): blue > 127.
                EXPECT_GT(shown[0], 127) << u << "," << v;
                EXPECT_EQ(shown[2], cv::saturate_cast<std::uint8_t>(0.35 * camera[2])) << u << "," << v;
                ++umbra;
            }
        }
    EXPECT_GT(umbra, 20);
    const std::uint8_t dimmed = cv::saturate_cast<std::uint8_t>(0.35 * 150.0); // OpenCV rounds half to even: 52
    EXPECT_EQ(run.out.withGi.at<cv::Vec3b>(0, 0), cv::Vec3b(dimmed, dimmed, dimmed))
        << "far pixels: the camera at 35 %";
    EXPECT_GT(dimmed, 0);
}

} // namespace
