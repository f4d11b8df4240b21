#pragma once
// Real spherical harmonics of order 2 (bands l = 0, 1, 2: nine functions) for irradiance environments.
//
// Basis: the real, orthonormal SH over the unit sphere (integral of Y_k Y_j over the sphere = delta_kj), in
// the order k = (l, m) = (0,0), (1,-1), (1,0), (1,1), (2,-2), (2,-1), (2,0), (2,1), (2,2), evaluated at a
// unit direction (x, y, z) given in the world frame:
//   Y_0 = 1/2 sqrt(1/pi)            Y_1 = sqrt(3/(4 pi)) y    Y_2 = sqrt(3/(4 pi)) z    Y_3 = sqrt(3/(4 pi)) x
//   Y_4 = 1/2 sqrt(15/pi) x y       Y_5 = 1/2 sqrt(15/pi) y z Y_6 = 1/4 sqrt(5/pi) (3 z^2 - 1)
//   Y_7 = 1/2 sqrt(15/pi) x z       Y_8 = 1/4 sqrt(15/pi) (x^2 - y^2)
//
// Irradiance (Ramamoorthi & Hanrahan 2001, "An efficient representation for irradiance environment maps"):
// E(n) = integral over the sphere of L(w) max(0, n.w) dw is the convolution of the incident radiance L with
// the clamped cosine, a kernel that depends only on the angle to n (zonal). By the Funk-Hecke theorem such a
// convolution multiplies every SH band l by one number,
//   Ahat_l = 2 pi integral_0^1 t P_l(t) dt        (P_l the Legendre polynomial, t = cos theta),
// so E_k = Ahat_l L_k. The first three:
//   l = 0: P_0 = 1,              2 pi * 1/2                     = pi
//   l = 1: P_1 = t,              2 pi * 1/3                     = 2 pi / 3
//   l = 2: P_2 = (3 t^2 - 1)/2,  2 pi * (3/4 - 1/2)/2 = 2 pi/8  = pi / 4
// (R&H's 3.141593, 2.094395, 0.785398.) Bands l >= 3 hold less than 1 % of the clamped cosine's energy for
// even l and nothing for odd l > 1, which is why nine coefficients represent irradiance well: for a single
// directional light, the order-2 irradiance is off by at most 0.0625 E0 at the light's direction and
// 0.094 E0 at its horizon (E0 the irradiance facing the light); SphericalHarmonicsTest checks these numbers.
//
// Units: whatever the radiance is in (here the camera's linear pixel values, see LightEstimate.h).

#include <glm/vec3.hpp>

#include <array>

namespace lightskin::roomlight {

inline constexpr int kShCount = 9;
inline constexpr double kPi = 3.14159265358979323846;

/// Coefficients of one function over the sphere per RGB channel: coefficients[k] = (r, g, b) of Y_k.
using ShRgb = std::array<glm::dvec3, kShCount>;
/// The nine basis functions at one direction.
using ShBasis = std::array<double, kShCount>;

/// The basis at unit direction `direction` (world frame). The direction is not normalised here.
ShBasis shBasis(const glm::dvec3& direction) noexcept;

/// Ahat_l of the band of coefficient k (pi, 2 pi/3 or pi/4): irradiance coefficient = Ahat * radiance coefficient.
double irradianceConvolution(int k) noexcept;

/// Irradiance E(n) from irradiance coefficients: sum_k coefficients[k] Y_k(n). n unit, world frame.
glm::dvec3 evaluateSh(const ShRgb& coefficients, const glm::dvec3& normal) noexcept;

/// Irradiance coefficients of a directional light: incident radiance a delta in direction
/// `towardLight` (unit) whose irradiance on a surface facing it is `irradianceFacing` (E0).
/// E_k = Ahat_l E0 Y_k(towardLight).
void addDirectionalLight(ShRgb& irradiance, const glm::dvec3& towardLight, const glm::dvec3& irradianceFacing) noexcept;

/// The dominant directional light of an irradiance environment, by the standard linear-band extraction
/// (Sloan 2008, "Stupid spherical harmonics tricks"): the direction is that of the luminance's band-1
/// radiance vector (L_3, L_1, L_2) = (x, y, z); the light's E0 per channel is the least-squares fit of
/// E0 Y_k(d) to the radiance coefficients of bands 1 and 2 (band 0 is left to the ambient):
///   E0 = sum_{l>=1} L_k Y_k(d) / sum_{l>=1} Y_k(d)^2,  with sum_{l=1,2} Y_k(d)^2 = 8 / (4 pi) = 2 / pi.
struct ShDominantLight {
    glm::dvec3 towardLight{0.0, 0.0, 1.0}; ///< unit; (0,0,1) when the environment has no band-1 part
    glm::dvec3 irradianceFacing{0.0};      ///< E0 per channel, clamped to >= 0
};
ShDominantLight extractDominantLight(const ShRgb& irradiance) noexcept;

} // namespace lightskin::roomlight
