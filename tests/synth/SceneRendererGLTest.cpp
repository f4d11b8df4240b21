// GL tests of the synthetic renderer: exact depth, positions and normals, radiance against an
// independent CPU evaluation of the documented radiometry, tag corners against the ground-truth
// pose. Renders are 160x120 or 320x240 (llvmpipe is slow).
#include "GlTestEnvironment.h"

#include <lightskin/synth/Generator.h>
#include <lightskin/synth/SceneRenderer.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <numbers>
#include <string>

namespace lightskin::synth {
namespace {

using SceneRendererGLTest = test::GlTest;

std::string sceneJson(const std::string& body, const std::string& segment, const std::string& pathExtra = "") {
    return R"({"format": "lightskin-synth-scene", "version": 1, "name": "test",)" + body + R"("path": {"segments": [)" +
           segment + "]" + pathExtra + "}}";
}

// A test pattern with the AprilTag border layout (not a real tag: the real bit patterns come from
// libapriltag through tracking): 10 x 10 cells, a white quiet zone of one cell, an 8 x 8 black
// square with a white 4 x 4 window inside.
TagBitmap testTagBitmap(const std::string&, int) {
    TagBitmap bitmap;
    bitmap.cells = cv::Mat(10, 10, CV_8UC1, cv::Scalar(255));
    bitmap.cells(cv::Rect(1, 1, 8, 8)).setTo(0);
    bitmap.cells(cv::Rect(3, 3, 4, 4)).setTo(255);
    bitmap.borderStartCell = 1;
    bitmap.borderCells = 8;
    return bitmap;
}

// z of the plane n . X = d (camera frame) seen through pixel (u,v).
double planeDepth(const CameraIntrinsics& k, const glm::dvec3& n, double d, int u, int v) {
    return d / glm::dot(n, k.backProject(u, v, 1.0));
}

TEST_F(SceneRendererGLTest, DepthOfAFrontoParallelWallIsExact) {
    // Camera 2.5 m from the east wall (x = 4), looking straight at it: every pixel sees the wall.
    const SceneDescription scene = parseSceneDescription(
        sceneJson(R"("camera": {"width": 160, "height": 120}, "render": {"supersampling": 1},)",
                  R"({"type": "hold", "position": [1.5, 1.75, 1.3], "target": [4, 1.75, 1.3]})"),
        "wall");
    Generator generator = Generator::create(scene, testTagBitmap);
    SynthFrame frame;
    generator.renderFrameInto(0, frame);
    double largest = 0.0;
    for (int v = 0; v < 120; ++v)
        for (int u = 0; u < 160; ++u) largest = std::max(largest, std::abs(double(frame.exact.depthMetres.at<float>(v, u)) - 2.5));
    EXPECT_LT(largest, 3e-6); // float precision at 2.5 m
    // In the recording's 16-bit millimetres: exactly 2500 everywhere.
    EXPECT_EQ(cv::countNonZero(frame.frame.depth != 2500), 0);
    EXPECT_EQ(frame.frame.depthScaleMetres, 0.001);
    frame.frame.validate("synth");
}

TEST_F(SceneRendererGLTest, DepthPositionsAndNormalsOfAnObliqueWallAreExact) {
    // Looking at the east wall at 35 degrees yaw, tilted down: the wall x = 4 is a plane at an angle.
    const SceneDescription scene = parseSceneDescription(
        sceneJson(R"("camera": {"width": 160, "height": 120}, "render": {"supersampling": 1},)",
                  R"({"type": "hold", "position": [2, 1.2, 1.3], "target": [4, 2.6, 1.0]})"),
        "oblique");
    Generator generator = Generator::create(scene, testTagBitmap);
    SynthFrame frame;
    generator.renderFrameInto(0, frame);
    const Pose world_T_camera = *frame.frame.groundTruth_world_T_camera;
    const Pose camera_T_world = world_T_camera.inverse();
    // The plane x = 4 in the camera frame: n_c . X = d.
    const glm::dvec3 normalCamera = camera_T_world.transformDirection({1, 0, 0});
    const double d = glm::dot(normalCamera, camera_T_world.transformPoint({4, 0, 0}));
    int wallPixels = 0;
    double largestDepthError = 0.0, largestPositionError = 0.0, largestUnitsError = 0.0;
    const CameraIntrinsics& k = scene.intrinsics;
    for (int v = 0; v < k.height; ++v)
        for (int u = 0; u < k.width; ++u) {
            const cv::Vec3f p = frame.exact.worldPosition.at<cv::Vec3f>(v, u);
            const double z = frame.exact.depthMetres.at<float>(v, u);
            // Every pixel: the world position is the back-projected depth.
            const glm::dvec3 expected = world_T_camera.transformPoint(k.backProject(u, v, z));
            largestPositionError = std::max(largestPositionError, glm::length(glm::dvec3(p[0], p[1], p[2]) - expected));
            if (std::abs(p[0] - 4.0f) > 1e-4f) continue; // another surface
            ++wallPixels;
            const double exact = planeDepth(k, normalCamera, d, u, v);
            largestDepthError = std::max(largestDepthError, std::abs(z - exact));
            largestUnitsError = std::max(largestUnitsError, std::abs(frame.frame.depth.at<std::uint16_t>(v, u) - exact * 1000.0));
            const cv::Vec3f n = frame.exact.worldNormal.at<cv::Vec3f>(v, u);
            ASSERT_NEAR(n[0], -1.0f, 1e-6f);
        }
    EXPECT_GT(wallPixels, 5000);
    EXPECT_LT(largestDepthError, 2e-5);   // float interpolation at ~3 m
    EXPECT_LT(largestUnitsError, 0.5 + 0.02); // rounding to millimetres
    EXPECT_LT(largestPositionError, 5e-5);
}

// Independent CPU evaluation of the documented radiometry at one surface point (double precision).
struct CpuLight {
    glm::dvec3 position, normal, intensity;
    bool isotropic;
};
struct CpuBox {
    glm::dvec3 center, half;
};
glm::dvec3 cpuRadiance(const glm::dvec3& x, const glm::dvec3& n, const glm::dvec3& albedo, const std::vector<CpuLight>& lights,
                       const std::vector<CpuBox>& boxes) {
    glm::dvec3 irradiance(0.0);
    for (const CpuLight& light : lights) {
        // Rays start 0.1 mm off the surface so a box does not shadow its own faces.
        const glm::dvec3 toLight = light.position - (x + 1e-4 * n);
        const double distance = glm::length(toLight);
        const glm::dvec3 l = toLight / distance;
        const double cosReceiver = glm::dot(n, l);
        const double cosEmitter = light.isotropic ? 1.0 : -glm::dot(light.normal, l);
        if (cosReceiver <= 0.0 || cosEmitter <= 0.0) continue;
        bool blocked = false;
        for (const CpuBox& box : boxes) { // axis-aligned slab test on the segment x -> light
            double enter = 0.0, leave = 1.0;
            for (int a = 0; a < 3; ++a) {
                const double t0 = (box.center[a] - box.half[a] - x[a] - 1e-4 * n[a]) / toLight[a];
                const double t1 = (box.center[a] + box.half[a] - x[a] - 1e-4 * n[a]) / toLight[a];
                enter = std::max(enter, std::min(t0, t1));
                leave = std::min(leave, std::max(t0, t1));
            }
            blocked = blocked || enter < leave;
        }
        if (!blocked) irradiance += light.intensity * cosEmitter * cosReceiver / (distance * distance);
    }
    return albedo / std::numbers::pi * irradiance;
}

TEST_F(SceneRendererGLTest, RadianceFollowsTheDocumentedRadiometry) {
    // A point light (60 W grey) and a 2 x 2-sampled area light on the ceiling, a table casting
    // shadows, coloured walls. Albedos and powers are chosen per channel to check channel order.
    const SceneDescription scene = parseSceneDescription(
        sceneJson(R"("camera": {"width": 160, "height": 120}, "render": {"supersampling": 2, "exposure": 0.5},
                     "room": {"size": [4, 3.5, 2.6], "floor": [0.6, 0.4, 0.2], "west": [0.8, 0.1, 0.1], "east": [0.1, 0.7, 0.1]},
                     "boxes": [{"name": "table", "center": [2.2, 1.75, 0.375], "size": [1.0, 0.7, 0.75], "albedo": 0.5}],
                     "lights": [{"type": "point", "position": [1.2, 1.2, 2.0], "powerWatts": [60, 40, 20]},
                                {"type": "area", "position": [2.5, 2.2, 2.59], "facing": [0, 0, -1], "size": [0.5, 0.4],
                                 "samples": 2, "powerWatts": 30}],)",
                  R"({"type": "hold", "position": [0.5, 0.4, 2.0], "target": [2.2, 1.75, 0.4]})"),
        "radiance");
    Generator generator = Generator::create(scene, testTagBitmap);
    SynthFrame frame;
    generator.renderFrameInto(0, frame);

    std::vector<CpuLight> lights{{{1.2, 1.2, 2.0}, {}, glm::dvec3(60, 40, 20) / (4.0 * std::numbers::pi), true}};
    for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i) // samples at the cell centres; face frame x = +x, y = -y for facing -z, up +y
            lights.push_back({{2.5 + (i - 0.5) * 0.25, 2.2 - (j - 0.5) * 0.2, 2.59}, {0, 0, -1},
                              glm::dvec3(30.0 / (std::numbers::pi * 4.0)), false});
    const std::vector<CpuBox> boxes{{{2.2, 1.75, 0.375}, {0.5, 0.35, 0.375}}};
    const auto albedoAt = [&](const glm::dvec3& x) -> glm::dvec3 {
        if (x.z < 1e-4) return {0.6, 0.4, 0.2};
        if (x.x < 1e-4) return {0.8, 0.1, 0.1};
        if (x.x > 4 - 1e-4) return {0.1, 0.7, 0.1};
        if (x.z > 2.6 - 1e-4 && std::abs(x.x - 2.5) <= 0.25 && std::abs(x.y - 2.2) <= 0.2) return {-1, -1, -1}; // emitter
        if (std::abs(x.x - 2.2) <= 0.5 + 1e-4 && std::abs(x.y - 1.75) <= 0.35 + 1e-4 && x.z <= 0.75 + 1e-4) return glm::dvec3(0.5);
        return glm::dvec3(0.7); // other walls, ceiling (defaults: 0.7 walls, 0.8 ceiling)
    };

    int compared = 0, agreeing = 0, shadowed = 0;
    const CameraIntrinsics& k = scene.intrinsics;
    for (int v = 1; v + 1 < k.height; ++v)
        for (int u = 1; u + 1 < k.width; ++u) {
            // Skip pixels whose 3x3 neighbourhood spans two surfaces (supersampled averages differ there).
            const cv::Vec3f n0 = frame.exact.worldNormal.at<cv::Vec3f>(v, u);
            bool uniform = true;
            for (int dv = -1; dv <= 1; ++dv)
                for (int du = -1; du <= 1; ++du) uniform = uniform && frame.exact.worldNormal.at<cv::Vec3f>(v + dv, u + du) == n0;
            if (!uniform) continue;
            const cv::Vec3f p = frame.exact.worldPosition.at<cv::Vec3f>(v, u);
            const glm::dvec3 x(p[0], p[1], p[2]);
            glm::dvec3 albedo = albedoAt(x);
            if (x.z > 2.6 - 1e-4) albedo = glm::dvec3(0.8); // ceiling
            if (albedoAt(x).x < 0) continue;
            const glm::dvec3 expected = cpuRadiance(x, glm::dvec3(n0[0], n0[1], n0[2]), albedo, lights, boxes);
            const cv::Vec3f bgr = frame.exact.radiance.at<cv::Vec3f>(v, u);
            const glm::dvec3 rendered(bgr[2], bgr[1], bgr[0]);
            ++compared;
            const glm::dvec3 unshadowed = cpuRadiance(x, glm::dvec3(n0[0], n0[1], n0[2]), albedo, lights, {});
            if (glm::length(expected) < 0.5 * glm::length(unshadowed)) ++shadowed;
            // 2 %: the supersampled average over the pixel footprint against the value at its
            // centre, plus shadow edges crossing the pixel (counted as disagreements).
            if (glm::length(rendered - expected) <= 0.02 * glm::length(expected) + 1e-4) ++agreeing;
        }
    std::printf("radiance: %d of %d pixels within 2 %% of the CPU evaluation, %d at least half shadowed\n", agreeing, compared, shadowed);
    EXPECT_GT(compared, 10000);
    EXPECT_GT(shadowed, 100); // the table's shadow is in view
    EXPECT_GT(double(agreeing) / compared, 0.97);

    // Colour is the sRGB encoding of exposure * radiance.
    for (int v = 0; v < k.height; v += 7)
        for (int u = 0; u < k.width; u += 5) {
            const cv::Vec3f radiance = frame.exact.radiance.at<cv::Vec3f>(v, u);
            for (int c = 0; c < 3; ++c)
                ASSERT_EQ(frame.frame.colour.at<cv::Vec3b>(v, u)[c], encodeSrgb(0.5f * radiance[c])) << u << "," << v;
        }
}

// Finds the black border's outer edge in the rendered image, independently of the renderer: for
// points along each predicted edge, the sub-pixel position where the linear intensity profile
// across the edge crosses halfway between its dark and bright ends; a line through them per
// edge; corners as intersections of adjacent lines.
std::array<cv::Point2d, 4> measureBorderCorners(const cv::Mat& linearGrey, const std::array<cv::Point2d, 4>& predicted) {
    std::array<cv::Vec3d, 4> lines; // a x + b y = c, (a,b) unit
    for (int e = 0; e < 4; ++e) {
        const cv::Point2d a = predicted[std::size_t(e)], b = predicted[std::size_t((e + 1) % 4)];
        const cv::Point2d along = (b - a) / cv::norm(b - a);
        const cv::Point2d outward(along.y, -along.x); // corners go clockwise in the image: left of travel is inside
        std::vector<cv::Point2d> points;
        for (double t = 0.15; t <= 0.85; t += 0.02) {
            const cv::Point2d centre = a + (b - a) * t;
            const auto sample = [&](double s) {
                cv::Mat patch;
                cv::getRectSubPix(linearGrey, cv::Size(1, 1), cv::Point2f(centre + outward * s), patch, CV_32F);
                return double(patch.at<float>(0, 0));
            };
            const double dark = sample(-2.0), bright = sample(2.0), half = 0.5 * (dark + bright);
            for (double s = -2.0; s < 2.0; s += 0.05) {
                const double f0 = sample(s), f1 = sample(s + 0.05);
                if ((f0 - half) * (f1 - half) <= 0.0 && f0 != f1) {
                    points.push_back(centre + outward * (s + 0.05 * (half - f0) / (f1 - f0)));
                    break;
                }
            }
        }
        cv::Vec4d fit;
        cv::fitLine(points, fit, cv::DIST_L2, 0, 1e-6, 1e-6);
        const double nx = -fit[1], ny = fit[0];
        lines[std::size_t(e)] = {nx, ny, nx * fit[2] + ny * fit[3]};
    }
    std::array<cv::Point2d, 4> corners;
    for (int c = 0; c < 4; ++c) {
        const cv::Vec3d& l0 = lines[std::size_t((c + 3) % 4)];
        const cv::Vec3d& l1 = lines[std::size_t(c)];
        const double det = l0[0] * l1[1] - l0[1] * l1[0];
        corners[std::size_t(c)] = {(l0[2] * l1[1] - l0[1] * l1[2]) / det, (l0[0] * l1[2] - l0[2] * l1[0]) / det};
    }
    return corners;
}

TEST_F(SceneRendererGLTest, GroundTruthPoseReprojectsTagCornersOntoTheRenderedCorners) {
    // A 0.24 m tag on the north wall and one on the table top, seen obliquely along a short orbit
    // with shake. The surfaces under the tags are as white as the tags' quiet zone, so the
    // measurement's bright side is not biased where the quiet zone is thinner than its profile.
    const SceneDescription scene = parseSceneDescription(
        sceneJson(R"("camera": {"width": 320, "height": 240}, "render": {"supersampling": 3},
                     "room": {"north": 0.85},
                     "boxes": [{"center": [2, 1.75, 0.375], "size": [1.2, 0.8, 0.75], "albedo": 0.85}],
                     "lights": [{"type": "point", "position": [1.5, 1.5, 2.3], "powerWatts": 80}],
                     "ambientRadiance": 0.3,
                     "tags": [{"id": 1, "size": 0.24, "position": [2.1, 3.5, 1.0], "facing": [0, -1, 0], "up": [0, 0, 1]},
                              {"id": 2, "size": 0.2, "position": [2.0, 1.75, 0.75], "facing": [0, 0, 1], "up": [0, 1, 0]}],)",
                  R"({"type": "orbit", "frames": 3, "center": [2, 1.9, 0.9], "radius": 1.2, "height": 1.3,
                      "startDegrees": 230, "endDegrees": 290})",
                  R"(, "shake": {"translationStdMetres": 0.004, "rotationStdDegrees": 0.3})"),
        "tags");
    Generator generator = Generator::create(scene, testTagBitmap);
    SynthFrame frame;
    double worst = 0.0;
    int measuredTags = 0;
    for (int index = 0; index < generator.frameCount(); ++index) {
        generator.renderFrameInto(index, frame);
        cv::Mat grey;
        cv::cvtColor(frame.exact.radiance, grey, cv::COLOR_BGR2GRAY);
        const Pose camera_T_world = frame.frame.groundTruth_world_T_camera->inverse();
        for (const TagDescription& tag : scene.tags) {
            std::array<cv::Point2d, 4> predicted;
            bool inside = true;
            const auto corners = SceneRenderer::tagCornersWorld(tag);
            for (int c = 0; c < 4; ++c) {
                const glm::dvec2 p = scene.intrinsics.project(camera_T_world.transformPoint(corners[std::size_t(c)]));
                predicted[std::size_t(c)] = {p.x, p.y};
                inside = inside && p.x > 10 && p.y > 10 && p.x < scene.intrinsics.width - 10 && p.y < scene.intrinsics.height - 10;
            }
            if (!inside) continue;
            ++measuredTags;
            const auto measured = measureBorderCorners(grey, predicted);
            for (int c = 0; c < 4; ++c) {
                const double error = cv::norm(measured[std::size_t(c)] - predicted[std::size_t(c)]);
                worst = std::max(worst, error);
                EXPECT_LT(error, 0.5) << "frame " << index << " tag " << tag.id << " corner " << c;
            }
        }
    }
    std::printf("tag corners: worst distance between rendered and reprojected corners %.3f px over %d tags\n", worst, measuredTags);
    EXPECT_GE(measuredTags, 5);
}

TEST_F(SceneRendererGLTest, NoisyFramesAreReproducible) {
    const std::string json =
        sceneJson(R"("camera": {"width": 96, "height": 72}, "render": {"supersampling": 1}, "noise": {"seed": 3},
                     "boxes": [{"center": [2, 1.75, 0.375], "size": [1.2, 0.8, 0.75]}],
                     "lights": [{"type": "point", "position": [1.5, 1.5, 2.3], "powerWatts": 80}],)",
                  R"({"type": "hold", "position": [0.5, 0.5, 1.5], "target": [2, 1.75, 0.5]})");
    const SceneDescription scene = parseSceneDescription(json, "noisy");
    ASSERT_TRUE(scene.noise.enabled);
    Generator generator = Generator::create(scene, testTagBitmap);
    const auto first = generator.renderAll();
    const auto second = generator.renderAll();
    ASSERT_EQ(first.size(), 1u);
    EXPECT_EQ(cv::norm(first[0].frame.depth, second[0].frame.depth, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(first[0].frame.colour, second[0].frame.colour, cv::NORM_INF), 0.0);
    // Noise changed the depth, and left holes (the table's edges, its projector shadow).
    cv::Mat exactUnits;
    depthMetresToUnitsInto(first[0].exact.depthMetres, 0.001, exactUnits);
    EXPECT_GT(cv::countNonZero(first[0].frame.depth != exactUnits), 1000);
    EXPECT_GT(cv::countNonZero(first[0].frame.depth == 0), 10);
}

} // namespace
} // namespace lightskin::synth
