// The "objects really there" ground truth (synth/PresentObjects.h): a cube on the floor of an empty
// room under a point light, seen from above. With a black cube (no bounce, no ambient) the floor
// in its shadow goes exactly to 0 and the lit floor keeps its radiance exactly (the light ratio is
// 1); the cube's own pixels are black. With a white cube its top face shows at least its direct
// light (closed form) and at most that plus the whole hemisphere of the brightest room radiance,
// and the floor beside it gets brighter (its bounce).
#include "GlTestEnvironment.h"

#include <lightskin/synth/Generator.h>
#include <lightskin/synth/PresentObjects.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <numbers>

namespace lightskin::synth {
namespace {

using PresentObjectsGLTest = test::GlTest;

const std::string kRoom = R"({
  "format": "lightskin-synth-scene", "version": 1, "name": "present",
  "room": {"size": [3, 3, 2.5], "floor": 0.5},
  "lights": [{"type": "point", "position": [1.9, 1.5, 1.6], "powerWatts": 40}],
  "ambientRadiance": 0.0,
  "camera": {"width": 120, "height": 90},
  "render": {"exposure": 1.0, "supersampling": 1},
  "path": {"segments": [{"type": "hold", "frames": 1, "position": [1.5, 1.2, 1.6], "target": [1.5, 1.5, 0.0]}]}
})";
const glm::dvec3 kLight(1.9, 1.5, 1.6), kCentre(1.5, 1.5, 0.1);
constexpr double kHalf = 0.1, kIntensity = 40.0 / (4.0 * std::numbers::pi);

PresentObject cubeObject(float albedo) {
    PresentObject o;
    o.name = "cube";
    const glm::vec3 normals[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (const glm::vec3& n : normals) {
        const glm::vec3 u = std::abs(n.x) > 0.5f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0), v = glm::cross(n, u);
        const auto base = std::uint32_t(o.mesh.positions.size());
        for (const auto& [a, b] : {std::pair{-1.f, -1.f}, {1.f, -1.f}, {1.f, 1.f}, {-1.f, 1.f}}) {
            o.mesh.positions.push_back(glm::vec3(kCentre) + float(kHalf) * (n + a * u + b * v));
            o.mesh.normals.push_back(n);
        }
        o.mesh.indices.insert(o.mesh.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    }
    o.material.diffuseAlbedo = glm::vec3(albedo);
    o.material.specularAlbedo = glm::vec3(0.0f);
    return o;
}

// Independent slab test: the open segment a-b crosses the cube grown by `margin`.
bool segmentHitsCube(const glm::dvec3& a, const glm::dvec3& b, double margin) {
    double t0 = 1e-6, t1 = 1.0 - 1e-6;
    for (int axis = 0; axis < 3; ++axis) {
        const double lo = kCentre[axis] - kHalf - margin, hi = kCentre[axis] + kHalf + margin, d = b[axis] - a[axis];
        if (std::abs(d) < 1e-15) {
            if (a[axis] < lo || a[axis] > hi) return false;
            continue;
        }
        double ta = (lo - a[axis]) / d, tb = (hi - a[axis]) / d;
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
    }
    return t0 <= t1;
}

struct Rendered {
    SynthFrame frame;
    cv::Mat present;
};

Rendered render(float albedo) {
    const SceneDescription scene = parseSceneDescription(kRoom, "present.json");
    Generator generator = Generator::create(scene);
    Rendered r;
    generator.renderFrameInto(0, r.frame);
    const PresentObjects present = PresentObjects::create(scene, {cubeObject(albedo)}, apriltagBitmaps());
    present.renderInto(*r.frame.frame.groundTruth_world_T_camera, r.frame.exact, r.present);
    return r;
}

TEST_F(PresentObjectsGLTest, ABlackCubeShadowsTheFloorExactlyAndLeavesTheLitFloor) {
    const Rendered r = render(0.0f);
    ASSERT_TRUE(cv::checkRange(r.present));
    int umbra = 0, lit = 0, cube = 0;
    for (int v = 0; v < r.present.rows; ++v)
        for (int u = 0; u < r.present.cols; ++u) {
            const cv::Vec3f p = r.frame.exact.worldPosition.at<cv::Vec3f>(v, u);
            const glm::dvec3 x(p[0], p[1], p[2]);
            const cv::Vec3f before = r.frame.exact.radiance.at<cv::Vec3f>(v, u), after = r.present.at<cv::Vec3f>(v, u);
            if (x.z > 1e-3) continue; // the floor only (the walls are far outside the cube's shadow anyway)
            const glm::dvec3 eye = r.frame.frame.groundTruth_world_T_camera->translation();
            if (segmentHitsCube(eye, x, 0.005)) continue; // the camera sees the cube here (or its silhouette)
            if (segmentHitsCube(x, kLight, -0.005)) {     // 5 mm inside the shadow: no pixel-centre ambiguity
                EXPECT_EQ(after, cv::Vec3f(0, 0, 0)) << u << "," << v;
                ++umbra;
            } else if (!segmentHitsCube(x, kLight, 0.005)) {
                EXPECT_EQ(after, before) << u << "," << v
                                         << ": lit floor, the light ratio is exactly 1 and nothing bounces";
                ++lit;
            }
        }
    // The cube's own pixels: the camera ray meets the cube before the floor; black cube, no ambient.
    for (int v = 0; v < r.present.rows; ++v)
        for (int u = 0; u < r.present.cols; ++u)
            if (r.present.at<cv::Vec3f>(v, u) == cv::Vec3f(0, 0, 0) &&
                r.frame.exact.radiance.at<cv::Vec3f>(v, u)[1] > 0.0f)
                ++cube;
    EXPECT_GT(umbra, 30);
    EXPECT_GT(lit, 1000);
    EXPECT_GT(cube, umbra + 30) << "the cube itself covers pixels and is black";
}

TEST_F(PresentObjectsGLTest, AWhiteCubesTopShowsItsDirectLightAndBrightensTheFloorBesideIt) {
    const Rendered r = render(0.8f);
    ASSERT_TRUE(cv::checkRange(r.present));
    // The room bounce is at most the hemisphere of the brightest room radiance, E_room <= pi L_max,
    // and L_max <= rho_max / pi * I / d_min^2: the ceiling (albedo 0.8, the room's highest) 0.9 m
    // above the light is the nearest surface to it.
    const double roomMax = 0.8 / std::numbers::pi * kIntensity / (0.9 * 0.9);
    int top = 0, brighter = 0;
    const CameraIntrinsics& k = parseSceneDescription(kRoom, "present.json").intrinsics;
    const Pose& world_T_camera = *r.frame.frame.groundTruth_world_T_camera;
    for (int v = 0; v < r.present.rows; ++v)
        for (int u = 0; u < r.present.cols; ++u) {
            // The top face z = 0.2 along this pixel's ray.
            const glm::dvec3 eye = world_T_camera.translation(),
                             d = world_T_camera.transformDirection({(u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0});
            const glm::dvec3 y = eye + (kCentre.z + kHalf - eye.z) / d.z * d;
            if (std::abs(y.x - kCentre.x) < kHalf - 0.01 && std::abs(y.y - kCentre.y) < kHalf - 0.01) {
                const glm::dvec3 toLight = kLight - y;
                const double direct =
                    0.8 / std::numbers::pi * kIntensity * toLight.z / std::pow(glm::dot(toLight, toLight), 1.5);
                const double shown = double(r.present.at<cv::Vec3f>(v, u)[1]);
                EXPECT_GE(shown, direct * (1.0 - 1e-5)) << u << "," << v;
                EXPECT_LE(shown, direct + 0.8 * roomMax) << u << "," << v;
                ++top;
            }
            const cv::Vec3f p = r.frame.exact.worldPosition.at<cv::Vec3f>(v, u);
            const glm::dvec3 x(p[0], p[1], p[2]);
            const double distance = std::max(std::abs(x.x - kCentre.x), std::abs(x.y - kCentre.y));
            if (x.z < 1e-3 && distance > kHalf + 0.02 && !segmentHitsCube(eye, x, 0.005) && distance < kHalf + 0.1 &&
                !segmentHitsCube(x, kLight, 0.005) &&
                r.present.at<cv::Vec3f>(v, u)[1] > r.frame.exact.radiance.at<cv::Vec3f>(v, u)[1])
                ++brighter;
        }
    EXPECT_GT(top, 20);
    EXPECT_GT(brighter, 50) << "the lit floor next to a white cube receives its bounce";
}

} // namespace
} // namespace lightskin::synth
