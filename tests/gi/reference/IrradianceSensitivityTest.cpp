// gi::reference::irradianceNormalSensitivity against closed forms and against finite differences of
// the brute force's irradiance (reference::irradiance), which shares no code with the V-vector formula.
#include <lightskin/gi/reference/IrradianceSensitivity.h>
#include <lightskin/gi/reference/LightSkinReference.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace lightskin::test {
namespace {

using gi::VirtualAreaLight;

/// A small disc VAL at `position` facing the origin, grey flux.
VirtualAreaLight valAt(const glm::dvec3& position, float flux = 1.0f, float area = 1e-4f) {
    VirtualAreaLight l;
    l.position = glm::vec3(position);
    l.normal = glm::vec3(-glm::normalize(position));
    l.area = area;
    l.flux = glm::vec3(flux);
    return l;
}

TEST(IrradianceSensitivityTest, OneValGivesTheTangentOfItsIncidence) {
    // E = c cos(theta_i) for one VAL (t and c do not depend on n), so dE/dtheta / E = tan(theta_i):
    // 0 at normal incidence, 1 at 45 degrees, 4.899 at cos(theta_i) = 0.2. Tolerance: the VAL's
    // position is float (2^-24 relative per coordinate: its direction is off by < 1e-7 rad), and
    // dS/dtheta = 1 + tan^2(theta); 1e-6 (1 + tan^2) covers it tenfold.
    const glm::dvec3 n(0.0, 0.0, 1.0);
    for (const double theta : {0.0, 0.5, std::numbers::pi / 4.0, std::acos(0.2), 1.5}) {
        const VirtualAreaLight l = valAt(2.0 * glm::dvec3(std::sin(theta), 0.0, std::cos(theta)));
        EXPECT_NEAR(gi::reference::irradianceNormalSensitivity({&l, 1}, glm::dvec3(0.0), n), std::tan(theta),
                    1e-6 * (1.0 + std::tan(theta) * std::tan(theta)))
            << theta;
    }
    // Two VALs mirrored about the normal: their tangential pulls cancel, S = 0 (first order).
    const VirtualAreaLight pair[2] = {valAt({1.0, 0.0, 1.0}), valAt({-1.0, 0.0, 1.0})};
    EXPECT_NEAR(gi::reference::irradianceNormalSensitivity(pair, glm::dvec3(0.0), n), 0.0, 1e-12);
}

TEST(IrradianceSensitivityTest, MatchesFiniteDifferencesOfTheIrradiance) {
    // 300 VALs around the receiver (about half below its horizon, none closer than 0.3 m, so no VAL
    // crosses the horizon within the +-h tilt and the one-sided term is absent), 20 random normals.
    // Reference: the steepest relative slope of reference::irradiance (eq. 3, 4 summed over VALs) over
    // 720 tilt directions, central differences with h = 1e-5 rad (truncation O(h^2) ~ 1e-10; the
    // direction sampling misses the steepest by at most cos(0.25 deg) - 1 = 1e-5 relative). Tolerance
    // 1e-4 relative: both error terms with margin, far below any mistake in the formula.
    std::mt19937 random(12);
    std::uniform_real_distribution<double> unit(-1.0, 1.0), radius(0.3, 2.0), flux(0.1, 3.0);
    std::vector<VirtualAreaLight> vals;
    while (vals.size() < 300) {
        const glm::dvec3 d(unit(random), unit(random), unit(random));
        if (glm::length(d) < 0.1 || glm::length(d) > 1.0) continue;
        VirtualAreaLight l = valAt(radius(random) * glm::normalize(d), float(flux(random)), 4e-4f);
        l.flux = glm::vec3(float(flux(random)), float(flux(random)), float(flux(random)));
        // emitters turned away from the receiver by up to ~60 degrees (cos(theta_j) varies)
        l.normal = glm::vec3(
            glm::normalize(glm::dvec3(l.normal) + 0.6 * glm::dvec3(unit(random), unit(random), unit(random))));
        vals.push_back(l);
    }
    const auto luminance = [&](const glm::dvec3& n) {
        double y = 0.0;
        for (int c = 0; c < 3; ++c)
            y += (c == 0 ? 0.2126 : c == 1 ? 0.7152 : 0.0722) * gi::reference::irradiance(vals, glm::dvec3(0.0), n, c);
        return y;
    };
    const double h = 1e-5;
    for (int k = 0; k < 20; ++k) {
        const glm::dvec3 n = glm::normalize(glm::dvec3(unit(random), unit(random), unit(random)));
        const glm::dvec3 a0 =
            glm::normalize(glm::cross(n, std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0)));
        const glm::dvec3 a1 = glm::cross(n, a0);
        const double e = luminance(n);
        ASSERT_GT(e, 0.0);
        double steepest = 0.0;
        for (int i = 0; i < 720; ++i) {
            const double phi = 2.0 * std::numbers::pi * double(i) / 720.0;
            const glm::dvec3 a = std::cos(phi) * a0 + std::sin(phi) * a1;
            const double slope =
                (luminance(std::cos(h) * n + std::sin(h) * a) - luminance(std::cos(h) * n - std::sin(h) * a)) /
                (2.0 * h);
            steepest = std::max(steepest, std::abs(slope));
        }
        const double s = gi::reference::irradianceNormalSensitivity(vals, glm::dvec3(0.0), n);
        EXPECT_NEAR(s, steepest / e, 1e-4 * steepest / e) << "normal " << k;
        EXPECT_GT(s, 0.01); // an asymmetric set: a test that passed on S = 0 would prove nothing
    }
}

TEST(IrradianceSensitivityTest, NoLightAboveTheHorizonIsInfiniteAndInvalidValsAreIgnored) {
    const glm::dvec3 n(0.0, 0.0, 1.0);
    const VirtualAreaLight below = valAt({0.3, 0.0, -1.0});
    EXPECT_TRUE(std::isinf(gi::reference::irradianceNormalSensitivity({&below, 1}, glm::dvec3(0.0), n)));
    EXPECT_TRUE(std::isinf(gi::reference::irradianceNormalSensitivity({}, glm::dvec3(0.0), n)));
    EXPECT_TRUE(std::isnan(gi::reference::irradianceNormalSensitivity({&below, 1}, glm::dvec3(0.0), glm::dvec3(0.0))));
    // A zero-area VAL (culled, gi::ValOccupancyCull) with a huge flux at grazing incidence changes nothing.
    VirtualAreaLight set[2] = {valAt({0.0, 0.0, 1.0}), valAt({1.0, 0.0, 0.01}, 1e6f)};
    set[1].area = 0.0f;
    EXPECT_NEAR(gi::reference::irradianceNormalSensitivity(set, glm::dvec3(0.0), n), 0.0, 1e-12);
}

} // namespace
} // namespace lightskin::test
