// Ray-traced ground truth: unoccluded discs against the exact coaxial disc form factor, a blocker
// halfway against the analytic point-to-rectangle form factor, horizon and scale behaviour.
#include "common/TestMeshes.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/reference/RayTracedGroundTruth.h>

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace lightskin::test {
namespace {

using gi::GroundTruthReceiver;
using gi::GroundTruthResult;
using gi::GroundTruthSettings;

// A disc of `area` at `centre` facing `normal`, radiant exitance M = flux / area.
gi::VirtualAreaLight disc(glm::vec3 centre, glm::vec3 normal, float area, glm::vec3 flux) {
    gi::VirtualAreaLight val;
    val.position = centre;
    val.normal = glm::normalize(normal);
    val.area = area;
    val.flux = flux;
    return val;
}

// Exact irradiance factor of a coaxial facing disc of radius r at distance h: r^2 / (r^2 + h^2).
double coaxial(double r2, double h) { return r2 / (r2 + h * h); }

// Form factor (cosine-weighted, /pi) from a point to a parallel rectangle [0,a]x[0,b] at height h
// with one corner above the point (Howell's catalogue, B-3).
double cornerRectangle(double a, double b, double h) {
    const double A = a / h, B = b / h;
    return (A / std::sqrt(1 + A * A) * std::atan(B / std::sqrt(1 + A * A)) +
            B / std::sqrt(1 + B * B) * std::atan(A / std::sqrt(1 + B * B))) /
           (2 * std::numbers::pi);
}

GroundTruthResult evaluate(const gi::RayTracedGroundTruth& truth, std::span<const gi::VirtualAreaLight> vals,
                           const GroundTruthReceiver& receiver, const GroundTruthSettings& settings) {
    GroundTruthResult result;
    truth.compute(vals, std::span(&receiver, 1), std::span(&result, 1), settings);
    return result;
}

TEST(RayTracedGroundTruthTest, UnoccludedDiscsSumToTheAnalyticDiscFormFactors) {
    const gi::RayTracedGroundTruth empty = gi::RayTracedGroundTruth::create({});
    const std::vector<gi::VirtualAreaLight> vals = {
        disc({0, 0, 1.0f}, {0, 0, -1}, 0.3f, {1.0f, 2.0f, 3.0f}),
        disc({0, 0, 0.2f}, {0, 0, -1}, 0.01f, {0.5f, 0.5f, 0.5f}),
        disc({0, 0, 3.0f}, {0, 0, -1}, 2.0f, {4.0f, 0.0f, 1.0f}),
    };
    glm::dvec3 expected(0.0);
    for (const auto& val : vals)
        expected += glm::dvec3(val.flux) / double(val.area) *
                    coaxial(double(val.area) / std::numbers::pi, double(val.position.z));
    GroundTruthReceiver receiver;
    receiver.material.diffuseAlbedo = glm::vec3(0.5f);
    GroundTruthSettings stratified;
    stratified.discRings = 32;
    stratified.discSectors = 32;
    const GroundTruthResult result = evaluate(empty, vals, receiver, stratified);
    // Midpoint quadrature of a smooth integrand over 1024 equal-area cells: error ~1e-4.
    for (int c = 0; c < 3; ++c) {
        if (expected[c] == 0.0) continue;
        EXPECT_NEAR(result.irradiance[c] / expected[c], 1.0, 5e-4) << c;
        EXPECT_EQ(result.irradiance[c], result.unoccludedIrradiance[c]);
        EXPECT_NEAR(result.radiance[c], 0.5 / std::numbers::pi * result.irradiance[c], 1e-12);
    }
    GroundTruthSettings centre;
    centre.discRings = centre.discSectors = 1;
    const GroundTruthResult exact = evaluate(empty, vals, receiver, centre);
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(exact.irradiance[c], expected[c], 1e-12 * (1 + expected[c])); // eq. 3 is exact coaxially
}

// Blocker halfway: an opaque square of half side s at h/2 hides the central square of half side 2s
// of a disc at height h; the hidden irradiance is that square's form factor.
TEST(RayTracedGroundTruthTest, BlockerHalfwayHidesTheExpectedFraction) {
    const double h = 1.0, s = 0.1;
    TriangleMesh blocker = planeGrid(float(2 * s), 2, float(h / 2));
    const gi::GroundTruthMesh meshes[] = {{&blocker, glm::dmat4(1.0)}};
    const gi::RayTracedGroundTruth truth = gi::RayTracedGroundTruth::create(meshes);
    const float area = float(std::numbers::pi * 0.6 * 0.6);
    const gi::VirtualAreaLight val = disc({0, 0, float(h)}, {0, 0, -1}, area, glm::vec3(area)); // M = 1
    GroundTruthReceiver receiver;
    GroundTruthSettings settings;
    settings.discRings = 128;
    settings.discSectors = 256;
    const GroundTruthResult result = evaluate(truth, std::span(&val, 1), receiver, settings);
    const double total = coaxial(double(area) / std::numbers::pi, h);
    const double hidden = 4.0 * cornerRectangle(2 * s, 2 * s, h);
    EXPECT_NEAR(result.unoccludedIrradiance.x / total, 1.0, 1e-4);
    // Polar cells straddling the square's shadow edge: ~ perimeter cells / cells of that region (0.5 %).
    EXPECT_NEAR((result.unoccludedIrradiance.x - result.irradiance.x) / hidden, 1.0, 1e-2);
    std::printf("hidden fraction %.5f (analytic %.5f)\n", 1.0 - result.irradiance.x / result.unoccludedIrradiance.x,
                hidden / total);
    // Centre mode: the blocker covers the disc centre, so the whole disc counts as hidden.
    GroundTruthSettings centre;
    centre.discRings = centre.discSectors = 1;
    const GroundTruthResult binary = evaluate(truth, std::span(&val, 1), receiver, centre);
    EXPECT_EQ(binary.irradiance.x, 0.0);
    EXPECT_NEAR(binary.unoccludedIrradiance.x, total, 1e-9);
}

TEST(RayTracedGroundTruthTest, HorizonAndBackFacingDiscsAddNothing) {
    const gi::RayTracedGroundTruth empty = gi::RayTracedGroundTruth::create({});
    GroundTruthReceiver receiver;
    GroundTruthSettings settings;
    // Back-facing: the disc faces away from the receiver.
    const gi::VirtualAreaLight away = disc({0, 0, 1}, {0, 0, 1}, 0.1f, glm::vec3(1.0f));
    EXPECT_EQ(evaluate(empty, std::span(&away, 1), receiver, settings).unoccludedIrradiance, glm::dvec3(0.0));
    // Below the horizon.
    const gi::VirtualAreaLight below = disc({0, 0, -1}, {0, 0, 1}, 0.1f, glm::vec3(1.0f));
    EXPECT_EQ(evaluate(empty, std::span(&below, 1), receiver, settings).unoccludedIrradiance, glm::dvec3(0.0));
    // Straddling the horizon (a vertical disc of radius r centred at distance 1 in the receiver's
    // plane): only its upper half counts. In closed form, with y = (1, rho cos phi, rho sin phi),
    // cos(theta_j) = 1/d, cos(theta_i) = z/d, d^2 = 1 + rho^2:
    //   E = L_e int_0^r int_0^pi rho sin(phi) / (1 + rho^2)^2 rho dphi drho = L_e (atan r - r / (1 + r^2)),
    // below the full coaxial disc's M r^2 / (r^2 + 1). Quadrature error: the integrand is smooth and
    // vanishes (linearly in z) at the horizon, so the ~2 x 64 cells of 64 x 128 cut by it err by
    // ~(128 / 8192) x (1 / 64) = 2.4e-4 relative, plus the midpoint rule's O(1/cells): 2e-3.
    const gi::VirtualAreaLight straddling = disc({1, 0, 0}, {-1, 0, 0}, 0.2f, glm::vec3(0.2f));
    GroundTruthSettings fine;
    fine.discRings = 64;
    fine.discSectors = 128;
    const GroundTruthResult half = evaluate(empty, std::span(&straddling, 1), receiver, fine);
    const double r2 = double(straddling.area) / std::numbers::pi, r = std::sqrt(r2);
    const double emitted = double(straddling.flux.x) / (std::numbers::pi * double(straddling.area)); // L_e
    const double exact = emitted * (std::atan(r) - r / (1.0 + r2));
    EXPECT_NEAR(half.irradiance.x / exact, 1.0, 2e-3);
    EXPECT_LT(half.irradiance.x, std::numbers::pi * emitted * r2 / (r2 + 1.0)) << "below the full disc's form factor";
    // Invalid VALs are skipped, not propagated.
    gi::VirtualAreaLight broken = disc({0, 0, 1}, {0, 0, -1}, 0.1f, glm::vec3(1.0f));
    broken.flux.x = std::numeric_limits<float>::quiet_NaN();
    const gi::VirtualAreaLight zeroArea = disc({0, 0, 1}, {0, 0, -1}, 0.0f, glm::vec3(1.0f));
    const gi::VirtualAreaLight both[] = {broken, zeroArea};
    EXPECT_EQ(evaluate(empty, both, receiver, settings).irradiance, glm::dvec3(0.0));
}

// The same scene at 1e-3 m and 1e3 m: the hidden fraction is scale-free (relative ray epsilon).
TEST(RayTracedGroundTruthTest, SceneScaleDoesNotChangeTheHiddenFraction) {
    double fractions[3] = {};
    int i = 0;
    for (double scale : {1e-3, 1.0, 1e3}) {
        TriangleMesh blocker = planeGrid(0.2f, 1, 0.5f);
        TriangleMesh floor = planeGrid(4.0f, 1, 0.0f); // the receiver sits on this surface
        const gi::GroundTruthMesh meshes[] = {{&blocker, glm::scale(glm::dmat4(1.0), glm::dvec3(scale))},
                                              {&floor, glm::scale(glm::dmat4(1.0), glm::dvec3(scale))}};
        const gi::RayTracedGroundTruth truth = gi::RayTracedGroundTruth::create(meshes);
        const float area = float(std::numbers::pi * 0.36 * scale * scale);
        const gi::VirtualAreaLight val = disc({0, 0, float(scale)}, {0, 0, -1}, area, glm::vec3(area));
        GroundTruthReceiver receiver;
        receiver.position = {0.05 * scale, 0.0, 0.0};
        GroundTruthSettings settings;
        settings.discRings = 32;
        settings.discSectors = 64;
        const GroundTruthResult result = evaluate(truth, std::span(&val, 1), receiver, settings);
        ASSERT_GT(result.unoccludedIrradiance.x, 0.0);
        fractions[i++] = result.irradiance.x / result.unoccludedIrradiance.x;
    }
    EXPECT_GT(fractions[1], 0.5);
    EXPECT_LT(fractions[1], 0.99);
    EXPECT_NEAR(fractions[0], fractions[1], 2e-3);
    EXPECT_NEAR(fractions[2], fractions[1], 2e-3);
}

TEST(RayTracedGroundTruthTest, ThreadsGiveTheSameResultsAsOne) {
    TriangleMesh blocker = planeGrid(0.3f, 3, 0.5f);
    const gi::GroundTruthMesh meshes[] = {{&blocker, glm::dmat4(1.0)}};
    const gi::RayTracedGroundTruth truth = gi::RayTracedGroundTruth::create(meshes);
    std::vector<gi::VirtualAreaLight> vals;
    for (int i = 0; i < 20; ++i)
        vals.push_back(disc({0.05f * float(i - 10), 0.0f, 1.0f}, {0, 0.2f, -1}, 0.01f, glm::vec3(0.01f)));
    std::vector<GroundTruthReceiver> receivers(37);
    for (std::size_t i = 0; i < receivers.size(); ++i) receivers[i].position = {0.02 * double(i) - 0.37, 0.01, 0.0};
    std::vector<GroundTruthResult> one(receivers.size()), many(receivers.size());
    GroundTruthSettings settings;
    settings.threads = 1;
    truth.compute(vals, receivers, one, settings);
    settings.threads = 4;
    truth.compute(vals, receivers, many, settings);
    int shadowed = 0;
    for (std::size_t i = 0; i < receivers.size(); ++i) {
        EXPECT_EQ(one[i].irradiance, many[i].irradiance);
        shadowed += one[i].irradiance.x < one[i].unoccludedIrradiance.x;
    }
    EXPECT_GT(shadowed, 10);
}

TEST(RayTracedGroundTruthTest, GlossyLobeIsTheCoresEquationFive) {
    // eq. 5 as in lightskin_math.glsl: L_s = f_s c (k + 1) cos^k(gamma) M w (no cos(theta_i)). A
    // small disc straight above (cos(theta_i) = 1, so M w = E) and the viewer on the mirror
    // direction: cos(gamma) = 1 and L_s = f_s (k + 1) / (2 pi) E.
    const gi::RayTracedGroundTruth empty = gi::RayTracedGroundTruth::create({});
    // Area 1e-6 m^2: the disc spans 2.8e-4 rad, so cos^50 varies by < 1e-4 over it.
    const gi::VirtualAreaLight val = disc({0, 0, 2}, {0, 0, -1}, 1e-6f, glm::vec3(1e-6f));
    GroundTruthReceiver receiver;
    receiver.material.diffuseAlbedo = glm::vec3(0.0f);
    receiver.material.specularAlbedo = glm::vec3(0.3f);
    receiver.material.specularExponent = 50.0f;
    const double c = 1.0 / (2 * std::numbers::pi);
    const GroundTruthResult result = evaluate(empty, std::span(&val, 1), receiver, {});
    ASSERT_GT(result.irradiance.x, 0.0);
    EXPECT_NEAR(result.radiance.x / (0.3 * c * 51.0 * result.irradiance.x), 1.0, 1e-4);
    receiver.toViewer = glm::normalize(glm::dvec3(1, 0, 1)); // 45 degrees off the mirror direction
    const GroundTruthResult off = evaluate(empty, std::span(&val, 1), receiver, {});
    EXPECT_NEAR(off.radiance.x / (0.3 * c * 51.0 * std::pow(std::cos(std::numbers::pi / 4), 50.0) * off.irradiance.x),
                1.0, 1e-3);
    // No cos(theta_i): a disc 60 degrees off the normal, viewer on its mirror direction, gives
    // f_s c (k + 1) E / cos(60) (the normalised Phong lobe of before would give E x cos(60) x ...).
    const double theta = std::numbers::pi / 3;
    const gi::VirtualAreaLight tilted =
        disc({float(2 * std::sin(theta)), 0, float(2 * std::cos(theta))},
             {float(-std::sin(theta)), 0, float(-std::cos(theta))}, 1e-6f, glm::vec3(1e-6f));
    receiver.toViewer = glm::dvec3(-std::sin(theta), 0.0, std::cos(theta));
    GroundTruthSettings glossyC;
    glossyC.glossyC = 0.25;
    const GroundTruthResult slanted = evaluate(empty, std::span(&tilted, 1), receiver, glossyC);
    ASSERT_GT(slanted.irradiance.x, 0.0);
    EXPECT_NEAR(slanted.radiance.x / (0.3 * 0.25 * 51.0 * slanted.irradiance.x / std::cos(theta)), 1.0, 1e-3);
}

} // namespace
} // namespace lightskin::test
