// The SH basis and the irradiance constants against numbers computed here by quadrature from their definitions.
#include <lightskin/roomlight/SphericalHarmonics.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>

namespace lightskin::roomlight {
namespace {

// Midpoint quadrature over the sphere, 400 x 800 cells: for the smooth products below the error is O(h^2) ~ 1e-5;
// the clamped cosine's kink costs O(h) on one ring ~ 1e-4 relative. Tolerance 1e-3.
template <typename F>
void integrateSphere(F&& function) {
    constexpr int kTheta = 400, kPhi = 800;
    for (int i = 0; i < kTheta; ++i) {
        const double theta = (i + 0.5) * kPi / kTheta;
        const double solidAngle = std::sin(theta) * (kPi / kTheta) * (2.0 * kPi / kPhi);
        for (int j = 0; j < kPhi; ++j) {
            const double phi = (j + 0.5) * 2.0 * kPi / kPhi;
            function(glm::dvec3{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)},
                     solidAngle);
        }
    }
}

TEST(SphericalHarmonics, BasisIsOrthonormal) {
    std::array<std::array<double, kShCount>, kShCount> gram{};
    integrateSphere([&](const glm::dvec3& w, double dw) {
        const ShBasis y = shBasis(w);
        for (std::size_t a = 0; a < kShCount; ++a)
            for (std::size_t b = 0; b < kShCount; ++b) gram[a][b] += y[a] * y[b] * dw;
    });
    for (std::size_t a = 0; a < kShCount; ++a)
        for (std::size_t b = 0; b < kShCount; ++b) EXPECT_NEAR(gram[a][b], a == b ? 1.0 : 0.0, 1e-3) << a << "," << b;
}

// The convolution constants: project max(0, n.w) for a fixed n onto each Y_k and compare with Ahat_l Y_k(n)
// (Funk-Hecke). A wrong constant (e.g. pi/2 for band 2) fails by > 0.1.
TEST(SphericalHarmonics, IrradianceConstantsMatchTheClampedCosineProjection) {
    const glm::dvec3 n = glm::normalize(glm::dvec3(0.3, -0.5, 0.8));
    std::array<double, kShCount> projection{};
    integrateSphere([&](const glm::dvec3& w, double dw) {
        const double cosine = std::max(glm::dot(n, w), 0.0);
        const ShBasis y = shBasis(w);
        for (std::size_t k = 0; k < kShCount; ++k) projection[k] += cosine * y[k] * dw;
    });
    const ShBasis yn = shBasis(n);
    for (int k = 0; k < kShCount; ++k)
        EXPECT_NEAR(projection[static_cast<std::size_t>(k)], irradianceConvolution(k) * yn[static_cast<std::size_t>(k)],
                    1e-3)
            << "k = " << k;
    EXPECT_NEAR(irradianceConvolution(0), kPi, 1e-12);
    EXPECT_NEAR(irradianceConvolution(2), 2.0 * kPi / 3.0, 1e-12);
    EXPECT_NEAR(irradianceConvolution(6), kPi / 4.0, 1e-12);
}

// The order-2 irradiance of one directional light, from the closed-form Legendre series of the clamped cosine:
// 1/4 + 1/2 t + 5/16 (3 t^2 - 1)/2 ... at t = 1: 1.0625, at t = 0: 0.09375 (the header's truncation bounds).
TEST(SphericalHarmonics, DirectionalLightTruncation) {
    ShRgb sh{};
    const glm::dvec3 toward = glm::normalize(glm::dvec3(1.0, 2.0, 2.0));
    addDirectionalLight(sh, toward, glm::dvec3(1.0));
    EXPECT_NEAR(evaluateSh(sh, toward).x, 1.0625, 1e-9);
    const glm::dvec3 horizon = glm::normalize(glm::cross(toward, glm::dvec3(0.0, 0.0, 1.0)));
    EXPECT_NEAR(evaluateSh(sh, horizon).x, 0.09375, 1e-9);
    EXPECT_NEAR(evaluateSh(sh, -toward).x, 0.0625, 1e-9);
}

// Linear-band extraction of a directional light over a uniform ambient: direction exact, E0 exact (band 0 is
// left to the ambient; bands 1 and 2 of the light are exactly E0 Ahat_l Y_k(d)).
TEST(SphericalHarmonics, ExtractsTheDominantLight) {
    ShRgb sh{};
    const glm::dvec3 toward = glm::normalize(glm::dvec3(-0.4, 0.3, 0.85));
    addDirectionalLight(sh, toward, {0.9, 0.6, 0.3});
    sh[0] += glm::dvec3(0.5) / shBasis(toward)[0]; // uniform irradiance 0.5
    const ShDominantLight light = extractDominantLight(sh);
    EXPECT_LT(std::acos(std::min(glm::dot(light.towardLight, toward), 1.0)), 1e-9);
    EXPECT_NEAR(light.irradianceFacing.x, 0.9, 1e-9);
    EXPECT_NEAR(light.irradianceFacing.y, 0.6, 1e-9);
    EXPECT_NEAR(light.irradianceFacing.z, 0.3, 1e-9);
    const ShDominantLight none = extractDominantLight(ShRgb{});
    EXPECT_EQ(none.irradianceFacing, glm::dvec3(0.0));
}

} // namespace
} // namespace lightskin::roomlight
