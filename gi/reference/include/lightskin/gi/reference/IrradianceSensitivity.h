#pragma once
// How strongly the brute force's irradiance at a receiver depends on the receiver's normal: the
// relative change of E per radian of normal tilt, in the steepest direction (TUM fr3).
//
// With the point model (eq. 3, 4) E(n) = sum_j c_j max(n . t_j, 0), c_j = M_j w_j / cos(theta_i) >= 0
// and t_j the unit direction to VAL j, neither depending on n. Tilting n by a small angle delta toward
// a unit tangent a changes E at the rate dE/ddelta = a . V, V = sum_{j: n.t_j > 0} c_j t_j (the
// irradiance vector of the VALs above the horizon; E = n . V). So
//
//     S(x, n) = |V - (n . V) n| / (n . V) = tan(angle between n and V),
//
// and a change of the normal by Delta radians changes E by about S Delta relative to E (first order;
// VALs crossing the horizon add a one-sided term). One distant source at theta_i gives S = tan(theta_i):
// 1 at 45 degrees, 4.9 at cos(theta_i) = 0.2. Where light reaches a receiver only at grazing angles
// (a receiver facing a floor strip seen edge-on) S is large and the shading normal's variation from
// pixel to pixel shows in the light; eval::smoothSurfaceMaskInto takes S to tell such patches from
// ones whose light is smooth at the 5x5 scale (docs/BENCHMARKS.md, "TUM fr3").
//
// Units: world metres; S is dimensionless (per radian). E = 0 (no valid VAL above the horizon) gives
// +infinity: any tilt can change E by an unbounded relative amount. Flux is weighted by its linear
// luminance (0.2126 R + 0.7152 G + 0.0722 B), the quantity the speckle measure looks at.

#include <lightskin/gi/common/VirtualAreaLight.h>

#include <glm/vec3.hpp>

#include <span>

namespace lightskin::gi::reference {

/// S(x, n) above over every valid VAL (area > 0), with the formulas of lightskin_math.glsl (guards
/// G1, G2; the point model, as the brute force without G12). `normal` need not be unit length (it is
/// normalised); a zero or non-finite normal gives NaN.
double irradianceNormalSensitivity(std::span<const VirtualAreaLight> lights, const glm::dvec3& position,
                                   const glm::dvec3& normal);

} // namespace lightskin::gi::reference
