// Differential irradiance on real receivers: a virtual cube on a real floor casts an
// indirect shadow that matches the Embree ground truth with stratified discs, and a direct shadow
// of an in-room point light that matches the closed form; a red panel tints the floor with the
// panel's albedo ratio and the magnitude of a separate quadrature over the lit face; receivers
// beyond the stated region are untouched; nothing is NaN or inf.
#include "common/TestMeshes.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/differential/DifferentialIrradiance.h>
#include <lightskin/gi/reference/RayTracedGroundTruth.h>

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

namespace lightskin::test {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kHeight = 1.2; // camera above the floor, metres

// A camera kHeight above the floor z = 0 looking straight down (x right, image y = world -y).
CameraIntrinsics camera() {
    CameraIntrinsics k;
    k.width = 160;
    k.height = 120;
    k.fx = k.fy = 100.0;
    k.cx = 79.5;
    k.cy = 59.5;
    return k;
}
Pose world_T_camera() {
    const glm::dmat3 rotation(glm::dvec3(1, 0, 0), glm::dvec3(0, -1, 0),
                              glm::dvec3(0, 0, -1)); // columns: camera axes in the world
    return Pose(glm::quat_cast(rotation), glm::dvec3(0, 0, kHeight));
}
cv::Mat floorDepth() { return cv::Mat(120, 160, CV_32FC1, cv::Scalar(kHeight)); } // fronto-parallel floor

struct Box {
    glm::dvec3 lo, hi;
};
// Separately written slab test (not Embree): the open segment a-b crosses the box.
bool segmentHitsBox(const glm::dvec3& a, const glm::dvec3& b, const Box& box, double margin = 0.0) {
    double t0 = 1e-9, t1 = 1.0 - 1e-9;
    const glm::dvec3 d = b - a;
    for (int axis = 0; axis < 3; ++axis) {
        const double lo = box.lo[axis] - margin, hi = box.hi[axis] + margin;
        if (std::abs(d[axis]) < 1e-15) {
            if (a[axis] < lo || a[axis] > hi) return false;
            continue;
        }
        double ta = (lo - a[axis]) / d[axis], tb = (hi - a[axis]) / d[axis];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
        if (t0 > t1) return false;
    }
    return true;
}

gi::MeshInstance placed(const TriangleMesh& mesh, const glm::vec3& translation, glm::vec3 albedo = glm::vec3(0.5f),
                        glm::vec3 scale = glm::vec3(1.0f)) {
    gi::MeshInstance instance;
    instance.mesh = &mesh;
    instance.world_T_model = glm::scale(glm::translate(glm::mat4(1.0f), translation), scale);
    instance.material.diffuseAlbedo = albedo;
    return instance;
}

// A real wall at x = -0.6 (facing +x) as VALs of radiance 1 W/(sr m^2): 20 x 16 discs 5 cm apart.
std::vector<gi::VirtualAreaLight> wallVals() {
    std::vector<gi::VirtualAreaLight> vals;
    const float spacing = 0.05f;
    for (int i = 0; i < 20; ++i)
        for (int j = 0; j < 16; ++j) {
            gi::VirtualAreaLight v;
            v.position = glm::vec3(-0.6f, -0.5f + (float(i) + 0.5f) * spacing, (float(j) + 0.5f) * spacing);
            v.normal = glm::vec3(1, 0, 0);
            v.area = spacing * spacing;
            v.flux = glm::vec3(float(kPi) * v.area); // phi = pi L a with L = 1
            vals.push_back(v);
        }
    return vals;
}

bool finiteImage(const cv::Mat& m) { return cv::checkRange(m, true, nullptr, -1e30, 1e30); }

TEST(DifferentialIrradianceTest, IndirectContactShadowOfACubeMatchesTheRayTracedReference) {
    const TriangleMesh cubeMesh = cube(0.1f);
    const gi::MeshInstance instance = placed(cubeMesh, {0.0f, 0.0f, 0.1f}); // resting on the floor
    const Box box{{-0.1, -0.1, 0.0}, {0.1, 0.1, 0.2}};
    gi::DifferentialSettings settings;
    settings.emittersPerObject = 0; // the blocked light alone (the bounce is tested below)
    settings.receiverStride = 4;
    gi::DifferentialIrradiance differential = gi::DifferentialIrradiance::create(std::span(&instance, 1), settings);
    const std::vector<gi::VirtualAreaLight> vals = wallVals();
    gi::DifferentialImages images;
    differential.compute(floorDepth(), camera(), world_T_camera(), vals, {}, images);
    ASSERT_TRUE(finiteImage(images.deltaIrradiance) && finiteImage(images.irradianceWithout));

    const gi::GroundTruthMesh occluder{&cubeMesh, glm::translate(glm::dmat4(1.0), glm::dvec3(0, 0, 0.1))};
    const gi::RayTracedGroundTruth truth = gi::RayTracedGroundTruth::create(std::span(&occluder, 1));
    gi::GroundTruthSettings stratified; // 8 rings x 16 sectors per disc
    stratified.threads = 1;
    int compared = 0, deepShadows = 0;
    const int s = settings.receiverStride;
    for (int j = 0; j < differential.gridHeight(); ++j)
        for (int i = 0; i < differential.gridWidth(); ++i) {
            const gi::DifferentialReceiver& r = differential.receivers()[std::size_t(j * differential.gridWidth() + i)];
            if (!r.inRegion) continue;
            // Receivers under the cube are hidden by it in any composite; the test skips them.
            if (r.position.x > -0.1 && r.position.x < 0.1 && r.position.y > -0.1 && r.position.y < 0.1) continue;
            // Every other receiver from 25 cm in front of the wall (there the closest disc has
            // r^2/d^2 < 0.013) to the shadow side; the stratified reference is the slow part.
            if (r.position.x < -0.35 || r.position.x > 0.6 || std::abs(r.position.y) > 0.4 || (i + j) % 2 != 0)
                continue;
            ASSERT_NEAR(r.normal.z, 1.0, 1e-6);
            ASSERT_NEAR(r.position.z, 0.0, 1e-6);
            gi::GroundTruthReceiver receiver;
            receiver.position = r.position;
            receiver.normal = glm::dvec3(0, 0, 1);
            gi::GroundTruthResult reference;
            truth.compute(vals, std::span(&receiver, 1), std::span(&reference, 1), stratified);
            const double expected = reference.irradiance.x - reference.unoccludedIrradiance.x;

            // Tolerance. The differential counts a disc fully blocked or fully visible by its centre
            // ray (the centre form factor); the reference integrates 128 cells. (1) Discs a shadow
            // edge crosses: found with 65 independent slab-test samples (centre, 4 rings x 16
            // sectors); each can differ by its whole contribution (+10 % for the formula below).
            // (2) Fully blocked discs: eq. 3 against the exact disc integral differs by O(r^2 / d^2);
            // 2 max(r^2/d^2) of their sum. (3) A silhouette corner between the 65 samples hides less
            // than one sample cell, 1/64 of a disc: 1/64 of |expected|. (4) Float rounding: 1e-6 E.
            double partial = 0.0, blockedSum = 0.0, maxRatio = 0.0, allRatio = 0.0, horizon = 0.0;
            for (const gi::VirtualAreaLight& v : vals) {
                const glm::dvec3 centre(v.position), n(v.normal);
                const glm::dvec3 tangent(0, 1, 0), bitangent(0, 0, 1);
                const double radius = std::sqrt(double(v.area) / kPi);
                const bool centreBlocked = segmentHitsBox(r.position, centre, box);
                bool mixed = false;
                for (int ring = 1; ring <= 4 && !mixed; ++ring)
                    for (int sector = 0; sector < 16 && !mixed; ++sector) {
                        const double angle = 2.0 * kPi * sector / 16.0, rr = radius * ring / 4.0;
                        const glm::dvec3 y = centre + rr * (std::cos(angle) * tangent + std::sin(angle) * bitangent);
                        mixed = segmentHitsBox(r.position, y, box) != centreBlocked;
                    }
                const glm::dvec3 offset = centre - r.position;
                const double d2 = glm::dot(offset, offset);
                const double e = double(v.flux.x) / kPi * std::max(0.0, -glm::dot(n, offset)) / std::sqrt(d2) /
                                 (radius * radius + d2) * std::max(0.0, offset.z) / std::sqrt(d2);
                allRatio = std::max(allRatio, radius * radius / d2);
                if (double(v.position.z) < radius) horizon += 1.1 * e; // the floor's horizon cuts this disc
                if (mixed)
                    partial += 1.1 * e;
                else if (centreBlocked) {
                    blockedSum += e;
                    maxRatio = std::max(maxRatio, radius * radius / d2);
                }
            }
            const double tolerance = partial + 2.0 * maxRatio * blockedSum + std::abs(expected) / 64.0 +
                                     1e-6 * reference.unoccludedIrradiance.x;
            EXPECT_NEAR(r.deltaIrradiance.x, expected, tolerance)
                << "receiver at " << r.position.x << ", " << r.position.y;
            EXPECT_DOUBLE_EQ(r.deltaIrradiance.x, r.deltaIrradiance.z); // grey wall, grey shadow
            // The same discs without visibility: eq. 3 vs the exact integral, O(r^2/d^2) per disc,
            // plus the discs the floor's horizon cuts (the reference drops their lower part).
            EXPECT_NEAR(r.irradianceWithout.x, reference.unoccludedIrradiance.x,
                        2.0 * allRatio * reference.unoccludedIrradiance.x + horizon + 1e-9);
            // The image at a receiver's own pixel is the receiver's value (bilinear weight 1).
            const cv::Vec3f pixel = images.deltaIrradiance.at<cv::Vec3f>(j * s + s / 2, i * s + s / 2);
            EXPECT_NEAR(double(pixel[2]), r.deltaIrradiance.x, 1e-6 * std::abs(r.deltaIrradiance.x) + 1e-9);
            if (expected < -0.3 * reference.unoccludedIrradiance.x) ++deepShadows;
            ++compared;
        }
    EXPECT_GT(compared, 50);
    EXPECT_GT(deepShadows, 5) << "a contact shadow: receivers beside the cube lose > 30 % of the wall's light";
}

TEST(DifferentialIrradianceTest, DirectShadowOfAnInRoomPointLightIsTheClosedForm) {
    const TriangleMesh cubeMesh = cube(0.1f);
    const gi::MeshInstance instance = placed(cubeMesh, {0.0f, 0.0f, 0.1f});
    const Box box{{-0.1, -0.1, 0.0}, {0.1, 0.1, 0.2}};
    gi::DifferentialSettings settings;
    settings.emittersPerObject = 0;
    gi::DifferentialIrradiance differential = gi::DifferentialIrradiance::create(std::span(&instance, 1), settings);
    gi::DifferentialLightSource light;
    light.light.type = gi::VirtualLight::Type::Point;
    light.light.position = glm::vec3(-0.4f, 0.1f, 0.9f);
    light.light.intensity = glm::vec3(60.0f / float(4.0 * kPi));
    light.inRoom = true;
    gi::DifferentialImages images;
    differential.compute(floorDepth(), camera(), world_T_camera(), {}, std::span(&light, 1), images);
    ASSERT_TRUE(finiteImage(images.deltaIrradiance));
    int shadowed = 0, lit = 0, interpolated = 0;
    for (const gi::DifferentialReceiver& r : differential.receivers()) {
        if (!r.inRegion) continue;
        const glm::dvec3 l = glm::dvec3(light.light.position) - r.position;
        const double e = double(light.light.intensity.x) * l.z / std::pow(glm::dot(l, l), 1.5); // I cos / d^2
        // An interpolated receiver has E_without from its cell's corners: bilinear over at most 9.6 cm, within
        // 2.1 % of I cos / d^2 (the pixels' bound below); the lights' part of dE is exact at every receiver.
        EXPECT_NEAR(r.irradianceWithout.y, e, (r.gathered ? 1e-5 : 0.03) * e);
        interpolated += r.gathered ? 0 : 1;
        // Receivers whose ray grazes the box within 1 mm are ambiguous in float: skipped.
        const bool in = segmentHitsBox(r.position, glm::dvec3(light.light.position), box, -1e-3);
        const bool near = segmentHitsBox(r.position, glm::dvec3(light.light.position), box, 1e-3);
        if (in != near) continue;
        EXPECT_NEAR(r.deltaIrradiance.y, in ? -e : 0.0, 1e-5 * e) << r.position.x << ", " << r.position.y;
        if (in) {
            EXPECT_TRUE(r.gathered) << "a direct shadow is never interpolated";
        }
        (in ? shadowed : lit)++;
    }
    EXPECT_GT(shadowed, 20);
    EXPECT_GT(lit, 100);
    EXPECT_GT(interpolated, 50) << "the lit floor beyond the cube's near zone (0.6 m) is interpolated";

    // Pixels test their own shadow, so the edge is as sharp as the pixels: dE = -e at every affected pixel whose
    // own segment to the light crosses the box, 0 elsewhere. The light's e there is interpolated over at most
    // an adaptive cell, 4 receivers of 2 px (9.6 cm); e = I z_l / d^3 with d >= 0.9 m bends by at most
    // ~15 e / d^2, so bilinear interpolation misses at most (9.6 cm)^2 / 8 x 15 / 0.81 m^2 = 2.1 % of e:
    // tolerance 3 %.
    const CameraIntrinsics k = camera();
    int shadowedPixels = 0, litPixels = 0;
    for (int v = 0; v < k.height; ++v)
        for (int u = 0; u < k.width; ++u) {
            if (images.affected.at<std::uint8_t>(v, u) == 0) continue;
            const glm::dvec3 p = world_T_camera().transformPoint(k.backProject(u, v, kHeight));
            const glm::dvec3 l = glm::dvec3(light.light.position) - p;
            const double e = double(light.light.intensity.x) * l.z / std::pow(glm::dot(l, l), 1.5);
            const bool in = segmentHitsBox(p, glm::dvec3(light.light.position), box, -1e-3);
            if (in != segmentHitsBox(p, glm::dvec3(light.light.position), box, 1e-3)) continue;
            ASSERT_NEAR(images.deltaIrradiance.at<cv::Vec3f>(v, u)[1], in ? -e : 0.0, 0.03 * e) << u << ", " << v;
            (in ? shadowedPixels : litPixels)++;
        }
    EXPECT_GT(shadowedPixels, 100);
    EXPECT_GT(litPixels, 1000);
}

TEST(DifferentialIrradianceTest, ARedPanelTintsTheWhiteFloorWithItsAlbedoAndTheQuadratureMagnitude) {
    // A 0.01 x 0.4 x 0.3 m panel standing on the floor at x = 0 (faces +-x), lit from +x by an
    // in-room light (its own light on the floor is unchanged), so dE on the lit side is the
    // panel's bounce alone (its shadow falls on the -x side).
    const TriangleMesh unitCube = cube(0.5f);
    const glm::vec3 albedo(0.8f, 0.1f, 0.1f);
    const gi::MeshInstance instance = placed(unitCube, {0.0f, 0.0f, 0.15f}, albedo, {0.01f, 0.4f, 0.3f});
    gi::DifferentialSettings settings;
    settings.emittersPerObject = 1024;
    gi::DifferentialIrradiance differential = gi::DifferentialIrradiance::create(std::span(&instance, 1), settings);
    gi::DifferentialLightSource light;
    light.light.type = gi::VirtualLight::Type::Point;
    light.light.position = glm::vec3(0.6f, 0.0f, 0.5f);
    light.light.intensity = glm::vec3(5.0f);
    gi::DifferentialImages images;
    differential.compute(floorDepth(), camera(), world_T_camera(), {}, std::span(&light, 1), images);
    ASSERT_TRUE(finiteImage(images.deltaIrradiance));

    // Reference: the lit face x = 0.005 as a Lambertian emitter of radiance rho/pi I cos / d^2,
    // midpoint rule 200 x 150 over it (error O(h^2) with h = 2 mm, far below the tolerance).
    const auto quadrature = [&](const glm::dvec3& x) {
        double sum = 0.0;
        const int ny = 200, nz = 150;
        const double dy = 0.4 / ny, dz = 0.3 / nz;
        for (int a = 0; a < ny; ++a)
            for (int b = 0; b < nz; ++b) {
                const glm::dvec3 y(0.005, -0.2 + (a + 0.5) * dy, (b + 0.5) * dz);
                const glm::dvec3 toLight = glm::dvec3(light.light.position) - y;
                const double irradiance =
                    double(light.light.intensity.x) * toLight.x / std::pow(glm::dot(toLight, toLight), 1.5);
                const glm::dvec3 toX = x - y;
                const double d2 = glm::dot(toX, toX);
                const double cosY = toX.x / std::sqrt(d2), cosX = -toX.z / std::sqrt(d2);
                if (cosY > 0 && cosX > 0) sum += irradiance / kPi * cosY * cosX / d2 * dy * dz;
            }
        return sum; // irradiance at x per unit albedo
    };
    int checked = 0;
    for (const gi::DifferentialReceiver& r : differential.receivers()) {
        if (!r.inRegion || r.position.x < 0.15 || r.position.x > 0.3 || std::abs(r.position.y) > 0.1) continue;
        const double expectedRed = 0.8 * quadrature(r.position);
        // Tint: no VALs, a white light: every emitter's flux is rho E A, so dE_r / dE_g is the
        // panel's albedo ratio 8 up to float rounding of the sums (1e-5).
        EXPECT_NEAR(r.deltaIrradiance.x / r.deltaIrradiance.y, 8.0, 8e-5);
        EXPECT_DOUBLE_EQ(r.deltaIrradiance.y, r.deltaIrradiance.z);
        // Magnitude: 1024 emitters over the box's area 0.254 m^2, the lit face gets ~480 (spacing
        // h ~ 1.6 cm) at distances d >= 0.15 m: the centre-disc sum approximates the integral with
        // relative error ~ (h/d)^2 ~ 1 % per emitter near the face plus the emitters' irradiance
        // taken at one point; the top edge face (0.4 x 0.01, lit) adds < 1 %: 10 % covers all.
        EXPECT_NEAR(r.deltaIrradiance.x, expectedRed, 0.1 * expectedRed) << r.position.x << ", " << r.position.y;
        EXPECT_GT(expectedRed, 0.05 * r.irradianceWithout.x) << "the bounce must be a visible fraction of the light";
        ++checked;
    }
    EXPECT_GT(checked, 10);
}

TEST(DifferentialIrradianceTest, ReceiversBeyondTheRegionStayExactlyUnchanged) {
    const TriangleMesh cubeMesh = cube(0.1f);
    const gi::MeshInstance instance = placed(cubeMesh, {0.0f, 0.0f, 0.1f});
    gi::DifferentialSettings settings;
    settings.falloffFraction = 0.2f; // R = r sqrt(1/0.2 - 1) = 2 r = 0.35 m
    settings.receiverStride = 4;
    gi::DifferentialIrradiance differential = gi::DifferentialIrradiance::create(std::span(&instance, 1), settings);
    gi::DifferentialImages images;
    differential.compute(floorDepth(), camera(), world_T_camera(), wallVals(), {}, images);
    const double region = 2.0 * 0.1 * std::sqrt(3.0);
    // Receivers the cube hides from the camera, with all their neighbours, leave the region too: no pixel of
    // the real floor that the camera shows reads them. Hidden: the sight line crosses the box (slab test;
    // within 1 mm of its faces ambiguous in float, skipped).
    const Box box{{-0.1, -0.1, 0.0}, {0.1, 0.1, 0.2}};
    const glm::dvec3 eye = world_T_camera().translation();
    const std::span<const gi::DifferentialReceiver> receivers = differential.receivers();
    const int width = differential.gridWidth(), height = differential.gridHeight();
    const auto hiddenWithNeighbours = [&](int i, int j, double margin) {
        for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di) {
                if (i + di < 0 || j + dj < 0 || i + di >= width || j + dj >= height) continue;
                const gi::DifferentialReceiver& n = receivers[std::size_t((j + dj) * width + i + di)];
                if (!segmentHitsBox(n.position, eye, box, margin)) return false;
            }
        return true;
    };
    int outside = 0, inside = 0, dropped = 0;
    for (int j = 0; j < height; ++j)
        for (int i = 0; i < width; ++i) {
            const gi::DifferentialReceiver& r = receivers[std::size_t(j * width + i)];
            if (!r.valid) continue; // the image border: the normal window does not fit
            const bool surely = hiddenWithNeighbours(i, j, -1e-3), maybe = hiddenWithNeighbours(i, j, 1e-3);
            if (surely != maybe) continue;
            const double distance = glm::length(r.position - glm::dvec3(0, 0, 0.1));
            EXPECT_EQ(r.inRegion, distance <= region * (1.0 + 1e-6) && !surely) << distance;
            r.inRegion ? ++inside : ++outside;
            dropped += surely ? 1 : 0;
        }
    EXPECT_GT(inside, 10);
    EXPECT_GT(outside, 100);
    EXPECT_GE(dropped, 4) << "the floor under the cube (its 17 px side holds 4 x 4 receivers, 4 px apart)";
    // Pixels: affected only where a receiver of the region is among the 2x2 around them.
    const CameraIntrinsics k = camera();
    for (int v = 0; v < k.height; ++v)
        for (int u = 0; u < k.width; ++u) {
            const glm::dvec3 p = world_T_camera().transformPoint(k.backProject(u, v, kHeight));
            if (glm::length(p - glm::dvec3(0, 0, 0.1)) > region + 2.0 * settings.receiverStride * kHeight / k.fx) {
                ASSERT_EQ(images.affected.at<std::uint8_t>(v, u), 0);
                ASSERT_EQ(images.deltaIrradiance.at<cv::Vec3f>(v, u), cv::Vec3f(0, 0, 0));
            }
        }
    EXPECT_GT(cv::countNonZero(images.affected), 100);
}

// A room of 2 240 VALs on four walls around the floor (facing inward, 4 cm apart, radiance 1), in a
// shuffled input order, and two cubes: many receivers see many VALs behind the cubes.
std::vector<gi::VirtualAreaLight> roomVals() {
    std::vector<gi::VirtualAreaLight> vals;
    const float spacing = 0.04f;
    const auto wall = [&](glm::vec3 origin, glm::vec3 along, int count, glm::vec3 normal) {
        for (int i = 0; i < count; ++i)
            for (int k = 0; k < 16; ++k) {
                gi::VirtualAreaLight v;
                v.position =
                    origin + (float(i) + 0.5f) * spacing * along + glm::vec3(0, 0, (float(k) + 0.5f) * spacing);
                v.normal = normal;
                v.area = spacing * spacing;
                v.flux = glm::vec3(float(kPi) * v.area) * glm::vec3(1.0f, 0.8f, 0.6f); // phi = pi L a
                vals.push_back(v);
            }
    };
    wall({-0.8f, -0.6f, 0.0f}, {1, 0, 0}, 40, {0, 1, 0}); // y = -0.6
    wall({-0.8f, 0.6f, 0.0f}, {1, 0, 0}, 40, {0, -1, 0}); // y = +0.6
    wall({-0.8f, -0.6f, 0.0f}, {0, 1, 0}, 30, {1, 0, 0}); // x = -0.8
    wall({0.8f, -0.6f, 0.0f}, {0, 1, 0}, 30, {-1, 0, 0}); // x = +0.8
    // A fixed shuffle (a full-period LCG step): the input order is not the spatial one.
    std::vector<gi::VirtualAreaLight> shuffled(vals.size());
    for (std::size_t i = 0; i < vals.size(); ++i) shuffled[(i * 1237u) % vals.size()] = vals[i];
    return shuffled;
}

// The clusters that spare the per-pair tests are exact: dE of the indirect shadow (no emitters, no
// lights) equals the sum over every VAL pair of the blocked light, with blocking decided by a
// separately written slab test against the two boxes (not Embree, not the bounding spheres), and
// E_without equals the unoccluded double-precision sum of eq. 3/4 over all VALs. Every receiver is
// gathered and every VAL is its own shadow disc: the exact computation the approximations start from.
TEST(DifferentialIrradianceTest, ClusteredShadowPairsAreExactlyThePairsTheObjectsBlock) {
    const TriangleMesh big = cube(0.1f), small = cube(0.05f);
    const std::array<gi::MeshInstance, 2> instances{placed(big, {0.0f, 0.0f, 0.1f}),
                                                    placed(small, {0.35f, -0.2f, 0.05f})};
    const std::array<Box, 2> boxes{Box{{-0.1, -0.1, 0.0}, {0.1, 0.1, 0.2}}, Box{{0.3, -0.25, 0.0}, {0.4, -0.15, 0.1}}};
    gi::DifferentialSettings settings;
    settings.emittersPerObject = 0;
    settings.refineCell = 1;
    settings.shadowCluster = 1;
    gi::DifferentialIrradiance differential = gi::DifferentialIrradiance::create(instances, settings);
    const std::vector<gi::VirtualAreaLight> vals = roomVals();
    gi::DifferentialImages images;
    differential.compute(floorDepth(), camera(), world_T_camera(), vals, {}, images);

    int compared = 0, shadowed = 0;
    for (const gi::DifferentialReceiver& r : differential.receivers()) {
        if (!r.inRegion) continue;
        // Receivers on a box's footprint (+1 cm) start inside it: skipped (hidden in any composite).
        bool under = false;
        for (const Box& b : boxes)
            under = under || (r.position.x > b.lo.x - 0.01 && r.position.x < b.hi.x + 0.01 &&
                              r.position.y > b.lo.y - 0.01 && r.position.y < b.hi.y + 0.01);
        if (under) continue;
        glm::dvec3 blocked(0.0), unoccluded(0.0), magnitude(0.0), ambiguous(0.0);
        for (const gi::VirtualAreaLight& v : vals) {
            const glm::dvec3 offset = glm::dvec3(v.position) - r.position;
            const double d2 = glm::dot(offset, offset), d = std::sqrt(d2);
            const double r2 = double(v.area) / kPi;
            const double e = std::max(0.0, -glm::dot(glm::dvec3(v.normal), offset) / d) *
                             std::max(0.0, glm::dot(r.normal, offset) / d) / (kPi * (r2 + d2)); // eq. 3/4, w_j
            if (!(e > 0.0)) continue;
            const glm::dvec3 light = glm::dvec3(v.flux) * e;
            unoccluded += light;
            // Decided: the same answer with the boxes grown and shrunk by 0.1 mm (float positions and
            // Embree's float ray against the exact slab test). Undecided pairs may go either way.
            bool in = false, out = false;
            for (const Box& b : boxes) {
                in = in || segmentHitsBox(r.position, glm::dvec3(v.position), b, -1e-4);
                out = out || segmentHitsBox(r.position, glm::dvec3(v.position), b, 1e-4);
            }
            if (in != out)
                ambiguous += light;
            else if (in)
                blocked += light;
            magnitude += light;
        }
        // Tolerance: the undecided pairs, plus float rounding: the shadow's w_j in float (~10
        // operations, < 1e-6 relative each pair, 1e-5 of the blocked sum) and E_without's float sums
        // (2 240 terms in 140 blocks of 16: running-sum rounding <= (140 + 16) 6e-8 < 1e-5 of the sum,
        // and the kernel's 1/sqrt estimate + Newton step ~1e-7 per term: 2e-5 of the sum).
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(r.deltaIrradiance[c], -blocked[c], ambiguous[c] + 1e-5 * magnitude[c] + 1e-12)
                << "channel " << c << " at " << r.position.x << ", " << r.position.y;
            EXPECT_NEAR(r.irradianceWithout[c], unoccluded[c], 2e-5 * unoccluded[c] + 1e-12);
        }
        if (blocked.x > 0.1 * unoccluded.x) ++shadowed;
        ++compared;
    }
    EXPECT_GT(compared, 900); // of the 40 x 30 grid: all but the border and the footprints
    EXPECT_GT(shadowed, 60) << "receivers must lose a visible share of the room's light to the boxes";
    EXPECT_GT(images.shadowRays, 0);
    EXPECT_LT(images.shadowRays, std::int64_t(compared) * std::int64_t(vals.size()) / 4)
        << "the clusters must spare most pairs their tests and rays";
}

// The thread count decides who computes a receiver, never how: one thread and several give the same
// images and receivers bit for bit (the scene of the test above, with emitters and a light).
TEST(DifferentialIrradianceTest, ResultsDoNotDependOnTheThreadCount) {
    const TriangleMesh big = cube(0.1f), small = cube(0.05f);
    const std::array<gi::MeshInstance, 2> instances{placed(big, {0.0f, 0.0f, 0.1f}),
                                                    placed(small, {0.35f, -0.2f, 0.05f}, glm::vec3(0.8f, 0.2f, 0.1f))};
    gi::DifferentialIrradiance differential = gi::DifferentialIrradiance::create(instances);
    gi::DifferentialLightSource light;
    light.light.type = gi::VirtualLight::Type::Point;
    light.light.position = glm::vec3(-0.4f, 0.1f, 0.9f);
    light.light.intensity = glm::vec3(5.0f);
    const std::vector<gi::VirtualAreaLight> vals = roomVals();
    const int threads = cv::getNumThreads();
    std::array<gi::DifferentialImages, 2> images;
    std::array<std::vector<gi::DifferentialReceiver>, 2> receivers;
    for (std::size_t run = 0; run < 2; ++run) {
        cv::setNumThreads(run == 0 ? 1 : 4);
        differential.compute(floorDepth(), camera(), world_T_camera(), vals, std::span(&light, 1), images[run]);
        receivers[run].assign(differential.receivers().begin(), differential.receivers().end());
    }
    cv::setNumThreads(threads);
    const auto same = [](const cv::Mat& a, const cv::Mat& b) {
        return a.size() == b.size() && a.type() == b.type() &&
               std::equal(a.datastart, a.dataend, b.datastart, b.dataend);
    };
    EXPECT_TRUE(same(images[0].deltaIrradiance, images[1].deltaIrradiance));
    EXPECT_TRUE(same(images[0].irradianceWithout, images[1].irradianceWithout));
    EXPECT_TRUE(same(images[0].affected, images[1].affected));
    EXPECT_EQ(images[0].shadowRays, images[1].shadowRays);
    ASSERT_EQ(receivers[0].size(), receivers[1].size());
    int nonzero = 0;
    for (std::size_t i = 0; i < receivers[0].size(); ++i) {
        ASSERT_EQ(receivers[0][i].deltaIrradiance, receivers[1][i].deltaIrradiance) << i;
        ASSERT_EQ(receivers[0][i].irradianceWithout, receivers[1][i].irradianceWithout) << i;
        if (receivers[0][i].deltaIrradiance != glm::dvec3(0.0)) ++nonzero;
    }
    EXPECT_GT(nonzero, 1000) << "the comparison must cover real shadows and bounce";
}

// Adaptive cells against gathering every receiver (refineCell 1, which the tests above check against
// independent truths): two small cubes in the walled room, their shadows and bounce, seen at twice the
// resolution of the tests above. An interpolated receiver's dE / E_without is a convex combination of its
// cell's corners' (the ratio of two sums with the same positive weights), which are exact and spread by at
// most the tolerance; outside the near zones nothing peaks inside a cell, so the true ratio lies within
// the corners' range up to the curvature of a smooth falloff: the error stays below the tolerance. (The
// scene lights' part of dE is computed at every receiver: DirectShadowOfAnInRoomPointLightIsTheClosedForm.)
TEST(DifferentialIrradianceTest, AdaptiveCellsStayWithinTheirToleranceOfGatheringEveryReceiver) {
    const TriangleMesh a = cube(0.05f), b = cube(0.04f);
    const std::array<gi::MeshInstance, 2> instances{placed(a, {-0.3f, 0.2f, 0.05f}),
                                                    placed(b, {0.4f, -0.25f, 0.04f}, glm::vec3(0.8f, 0.2f, 0.1f))};
    CameraIntrinsics k = camera();
    k.width *= 2;
    k.height *= 2;
    k.fx = k.fy = 2.0 * k.fx;
    k.cx = 2.0 * k.cx + 0.5;
    k.cy = 2.0 * k.cy + 0.5;
    const cv::Mat depth(k.height, k.width, CV_32FC1, cv::Scalar(kHeight));
    const std::vector<gi::VirtualAreaLight> vals = roomVals();
    gi::DifferentialSettings every, adaptive;
    every.refineCell = every.shadowCluster = adaptive.shadowCluster = 1;
    ASSERT_EQ(adaptive.refineCell, 4) << "the default is what this test measures";
    std::array<gi::DifferentialImages, 2> images;
    std::array<std::vector<gi::DifferentialReceiver>, 2> receivers;
    for (std::size_t run = 0; run < 2; ++run) {
        gi::DifferentialIrradiance differential =
            gi::DifferentialIrradiance::create(instances, run == 0 ? every : adaptive);
        differential.compute(depth, k, world_T_camera(), vals, {}, images[run]);
        receivers[run].assign(differential.receivers().begin(), differential.receivers().end());
    }
    ASSERT_EQ(receivers[0].size(), receivers[1].size());
    const double tolerance = double(adaptive.refineTolerance);
    int interpolated = 0, varying = 0;
    double worst = 0.0;
    for (std::size_t i = 0; i < receivers[0].size(); ++i) {
        const gi::DifferentialReceiver &exact = receivers[0][i], &r = receivers[1][i];
        ASSERT_EQ(exact.inRegion, r.inRegion) << i;
        if (!r.inRegion) continue;
        ASSERT_TRUE(exact.gathered);
        if (r.gathered) {
            ASSERT_EQ(r.deltaIrradiance, exact.deltaIrradiance) << "a gathered receiver is the same computation";
            continue;
        }
        ++interpolated;
        for (int c = 0; c < 3; ++c) {
            const double q = exact.deltaIrradiance[c] / exact.irradianceWithout[c];
            worst = std::max(worst, std::abs(r.deltaIrradiance[c] / r.irradianceWithout[c] - q));
            varying += std::abs(q) > tolerance ? 1 : 0;
        }
    }
    EXPECT_LE(worst, tolerance);
    EXPECT_GT(interpolated, int(receivers[0].size() / 4)) << "most of the floor is far from both cubes";

    // A pixel is left as the camera saw it only if every receiver it reads has |dE| <= E_without / 510 (no light
    // here: dE is the VALs' and emitters' part); the composite then moves its code by at most 0.22 of a step.
    const int s = 4, width = k.width / s, height = k.height / s; // 320 px / 80 receivers
    int skipped = 0;
    for (int v = 0; v < k.height; ++v)
        for (int u = 0; u < k.width; ++u) {
            if (images[1].affected.at<std::uint8_t>(v, u) != 0) continue;
            const int i0 = int(std::floor(double(u - s / 2) / s)), j0 = int(std::floor(double(v - s / 2) / s));
            bool read = false;
            for (int j = j0; j <= j0 + 1; ++j)
                for (int i = i0; i <= i0 + 1; ++i) {
                    if (i < 0 || j < 0 || i >= width || j >= height) continue;
                    const gi::DifferentialReceiver& r = receivers[1][std::size_t(j * width + i)];
                    const bool weighted = std::abs(u - (i * s + s / 2)) < s && std::abs(v - (j * s + s / 2)) < s;
                    if (!r.inRegion || !weighted) continue;
                    read = true;
                    for (int c = 0; c < 3; ++c)
                        ASSERT_LE(std::abs(r.deltaIrradiance[c]), r.irradianceWithout[c] / 510.0) << u << ", " << v;
                }
            skipped += read ? 1 : 0;
        }
    EXPECT_GT(skipped, 100) << "the floor far from the cubes, where they change nothing visible";
    EXPECT_GT(cv::countNonZero(images[1].affected), k.width * k.height / 10);
    EXPECT_GT(varying, 30) << "the interpolated receivers must include some the cubes visibly change";
    EXPECT_LT(images[1].receiversGathered, images[0].receiversGathered / 2);
    EXPECT_EQ(images[0].receiversInRegion, images[1].receiversInRegion);
}

TEST(DifferentialIrradianceTest, RejectsBadSettings) {
    gi::DifferentialSettings settings;
    settings.falloffFraction = 1.0f;
    EXPECT_THROW(gi::validate(settings), Error);
    settings = {};
    settings.receiverStride = -1;
    EXPECT_THROW(gi::DifferentialIrradiance::create({}, settings), Error);
    settings = {};
    settings.refineCell = 0;
    EXPECT_THROW(gi::validate(settings), Error);
    settings = {};
    settings.refineTolerance = 0.0f;
    EXPECT_THROW(gi::validate(settings), Error);
}

// A moved object: place() gives what create() at the new placement gives (shadow, bounce and emitter albedo), bit
// for bit, and the result does change with the move (not a test of two empty images).
TEST(DifferentialIrradianceTest, PlacingAnObjectAnewEqualsCreatingItThere) {
    const TriangleMesh cubeMesh = cube(0.1f);
    const gi::MeshInstance at = placed(cubeMesh, {0.0f, 0.0f, 0.1f}, glm::vec3(0.5f));
    gi::MeshInstance moved = at;
    moved.world_T_model =
        glm::rotate(glm::translate(glm::mat4(1.0f), glm::vec3(0.12f, -0.05f, 0.1f)), 0.6f, glm::vec3(0.0f, 0.0f, 1.0f));
    moved.material.diffuseAlbedo = glm::vec3(0.9f, 0.2f, 0.1f);
    gi::DifferentialSettings settings;
    settings.emittersPerObject = 128;
    gi::DifferentialLightSource light;
    light.light.type = gi::VirtualLight::Type::Point;
    light.light.position = glm::vec3(-0.4f, 0.1f, 0.9f);
    light.light.intensity = glm::vec3(5.0f);
    const std::vector<gi::VirtualAreaLight> vals = wallVals();
    const auto run = [&](gi::DifferentialIrradiance& d) {
        gi::DifferentialImages images;
        d.compute(floorDepth(), camera(), world_T_camera(), vals, std::span(&light, 1), images);
        return images;
    };
    gi::DifferentialIrradiance placedAnew = gi::DifferentialIrradiance::create(std::span(&at, 1), settings);
    const gi::DifferentialImages before = run(placedAnew);
    placedAnew.place(std::span(&moved, 1));
    const gi::DifferentialImages after = run(placedAnew);
    gi::DifferentialIrradiance createdThere = gi::DifferentialIrradiance::create(std::span(&moved, 1), settings);
    const gi::DifferentialImages reference = run(createdThere);
    EXPECT_EQ(cv::norm(after.deltaIrradiance, reference.deltaIrradiance, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(after.affected, reference.affected, cv::NORM_INF), 0.0);
    EXPECT_EQ(after.shadowRays, reference.shadowRays);
    EXPECT_GT(cv::norm(after.deltaIrradiance, before.deltaIrradiance, cv::NORM_INF), 0.01)
        << "the move changed nothing";
    EXPECT_GT(cv::countNonZero(after.affected), 100);
}

} // namespace
} // namespace lightskin::test
