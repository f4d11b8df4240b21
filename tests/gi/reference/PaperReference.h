#pragma once
// An INDEPENDENT double-precision implementation of the LightSkin equations (Lensing & Broll,
// ../shared/papers/000_*.txt (the LightSkin paper), eq. 3-5, 7, 10-14), written from the paper for the tests. It
// does not include gi/lightskin/shaders/lightskin_math.glsl or gi/lightskin/src/LightSkinMath.h (which compile the same
// source as the shaders, so a formula error there would cancel) and deliberately computes
// differently where the maths allows it: absolute light positions and two-pass variances instead
// of receiver-relative moment sums, cos(gamma) by reflecting the VIEW vector instead of the light
// vector, std::pow instead of exp(k log c), plain loops over the 8 neighbours.
//
// It follows the core's documented deviations from the paper (lightskin_math.glsl, "Deviations"),
// each kept as one visible line here so that a change of the core shows up as a test failure:
//  * the paper's phi_j acts as the radiant exitance M_j = flux_j / area_j (units);
//  * D = |x - l'|^2 + rbar^2 in eq. 10/11 (rbar^2 = weighted mean r_j^2);
//  * both channels only take VALs above the receiver's horizon (cos(theta_i) > 0);
//  * S_o radius: max per-axis sigma (diffuse), sqrt(trace / 3) (glossy);
//  * occluders between the near side and the centre of S_o count linearly less.
// The renormalisation clamp (guard G4: divide by max(cos, floor)) is a separate parameter,
// Options::renormalisationFloor, because it is a design choice that may change.
//
// Units: world metres; VAL flux in W (linear RGB); irradiance W/m^2; radiance W/(sr m^2).
#include <lightskin/gi/common/SparsePointSet.h>
#include <lightskin/gi/common/VirtualAreaLight.h>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <numbers>
#include <span>
#include <vector>

namespace lightskin::test::paper {

struct Options {
    double c = 1.0 / (2.0 * std::numbers::pi); ///< c of c_k = c (k + 1), 1/sr
    double epsilonL = 1e-20;                   ///< eps_l of eq. 7
    bool glossy = true;                        ///< false: the glossy channel stays 0
    double renormalisationFloor = 1e-3;        ///< eq. 11 divides by max(cos, this) (core guard G4)
    /// The core's guard G9: the diffuse VPL is a uniformly bright sphere of its S_o radius,
    /// clipped by the receiver's horizon, in eq. 10 and 11 (horizonFactor); false: a point.
    bool extendedVplHorizon = true;
};

/// Guard G9's cosine factor, computed here by quadrature from its definition: the integral of
/// max(n . w, 0) over the directions w of a cone of half-angle sigma (sin^2 sigma = sin2) whose axis
/// makes cos(theta) = cosTheta with n, divided by pi sin^2 sigma (the unclipped integral). Equals
/// max(cosTheta, 0) for sin2 <= 1e-6 (the core's floor: sigma < 1e-3 rad counts as a point).
double horizonFactor(double cosTheta, double sin2);

struct Point {
    glm::dvec3 position{0.0};
    glm::dvec3 normal{0.0, 0.0, 1.0}; ///< unit
    double exponent = 1.0;            ///< Phong k
    double occluderRadius = 0.0;      ///< metres (section 3.3 occluder disc)
};

/// One averaged light of eq. 7 (before renormalisation) with the quantities eq. 11 and 3.3 need.
struct Averaged {
    glm::dvec3 sum{0.0};      ///< L' (diffuse: irradiance W/m^2; glossy: radiance per unit f_s)
    double weight = 0.0;      ///< W (eps_l included)
    glm::dvec3 position{0.0}; ///< l', absolute world metres
    double meanR2 = 0.0;      ///< rbar^2 = sum r_j^2 weight_j / W
    glm::dvec3 variance{0.0}; ///< per-axis weighted variance of l_j about l'
};
struct PointGather {
    Averaged diffuse, glossy;
};

/// A renormalised VPL (L'', l', rbar^2) with its occlusion sphere radius.
struct Light {
    glm::dvec3 radiance{0.0};
    glm::dvec3 position{0.0};
    double r2 = 0.0;
    double sphereRadius = 0.0;
};
struct LightPair {
    Light diffuse, glossy;
};

/// eq. 3: w_j = r^2 cos(theta_j) / (r^2 + |x - l|^2), cos(theta_j) clamped at 0.
double discWeight(const gi::VirtualAreaLight& val, const glm::dvec3& x);
/// cos(gamma) of eq. 5: angle between the mirror direction and the observer direction.
double cosGamma(const glm::dvec3& normal, const glm::dvec3& toLight, const glm::dvec3& toEye);

/// eq. 3-5, 7 at one point.
PointGather gather(std::span<const gi::VirtualAreaLight> vals, const Point& x, const glm::dvec3& eye,
                   const Options& options);
/// eq. 11 (with the deviations above) for both channels.
LightPair renormalise(const PointGather& g, const Point& x, const glm::dvec3& eye, const Options& options);
/// Section 3.3 / eq. 14: occlusion amounts (diffuse, glossy) of point i's S_o spheres by the
/// occluder discs of all other points, each clamped to [0, 1].
glm::dvec2 occlusion(std::span<const Point> points, std::span<const LightPair> lights, std::size_t i);
/// eq. 12 (+ the core's fallbacks when every weight vanishes) normalised as in eq. 13.
std::array<double, gi::kVertexNeighbours>
vertexWeights(const glm::dvec3& vertex, const glm::dvec3& vertexNormal,
              const std::array<std::uint32_t, gi::kVertexNeighbours>& neighbours, std::span<const Point> points);
/// eq. 13: the weighted VPLs of one vertex. With `distanceFloor` (the core's guard G8)
/// the vertex VPL is never nearer, in D = |v - l|^2 + rbar^2, than the nearest VPL of the sparse
/// points it averages was to its own point: rbar^2 grows by the shortfall.
LightPair interpolate(const glm::dvec3& vertex, const glm::dvec3& vertexNormal,
                      const std::array<std::uint32_t, gi::kVertexNeighbours>& neighbours, std::span<const Point> points,
                      std::span<const LightPair> lights, bool distanceFloor = true);
// (interpolate also averages the diffuse S_o radius with the same weights, for G9's shading.)
/// eq. 10: radiance toward `eye` of a surface with rho_d, f_s, k lit by one VPL pair.
glm::dvec3 shade(const LightPair& lights, const glm::dvec3& p, const glm::dvec3& n, const glm::dvec3& eye,
                 const glm::dvec3& rhoD, const glm::dvec3& fs, double k);

/// The whole technique on a point set: gather, renormalise, optional occlusion (applied to L'').
struct Run {
    std::vector<PointGather> gathers;
    std::vector<LightPair> lights;     ///< before occlusion
    std::vector<glm::dvec2> occlusion; ///< 0 when occlusion is off
    std::vector<LightPair> occluded;   ///< L'' (1 - o)
};
Run run(std::span<const gi::VirtualAreaLight> vals, std::span<const Point> points, const glm::dvec3& eye,
        const Options& options, bool withOcclusion);

} // namespace lightskin::test::paper
