#pragma once
// The data of LightSkin's gather in double precision, shared by the CPU backend's gather with a cut
// (gi/lightskin/src/ValTreeWalk.h) and the references (lightskin/gi/reference/LightSkinReference.h,
// ValTreeReference.h), which name them in their namespace.
// Units: world frame, metres; irradiance W/m^2; glossy sums W/(sr m^2) per unit f_s.

#include <glm/vec3.hpp>

#include <cstdint>
#include <numbers>

namespace lightskin::gi::gather {

/// Parameters shared by the gather and the brute force.
struct GatherParameters {
    double cParameter = 1.0 / (2.0 * std::numbers::pi); ///< c of c_k = c (k + 1), 1/sr (normalised Phong)
    double epsilonL = 1e-20;                            ///< eps_l of eq. 7 (dimensionless weight added per VAL)
    bool glossy = true;                                 ///< false: the glossy sums stay 0 (the paper's "diffuse" setup)
    bool nearField = false; ///< guard G12 of lightskin_math.glsl (near-field VALs as areas); false: point model
};

/// A receiver: a sparse point in world space with its material exponent.
struct Receiver {
    glm::dvec3 position{0.0};         ///< world metres
    glm::dvec3 normal{0.0, 0.0, 1.0}; ///< unit, world
    double exponent = 1.0;            ///< Phong k of the point's material
    double occluderRadius = 0.0;      ///< world metres (section 3.3 occluder disc)
};

/// The eq.-7 sums of one receiver (positions relative to the receiver).
struct GatherSums {
    glm::dvec3 irradiance{0.0}; ///< L'_d = sum E_j, W/m^2
    double weightD = 0.0;       ///< W_d
    glm::dvec3 offsetD{0.0};    ///< sum (l_j - x) w_d,j
    double r2D = 0.0;           ///< sum r_j^2 w_d,j
    glm::dvec3 momentD{0.0};    ///< sum (l_j - x)^2 w_d,j per axis (S_o)
    glm::dvec3 glossy{0.0};     ///< L'_s = c_k sum M_j w_j cos^k(gamma), W/(sr m^2) per unit f_s
    double weightS = 0.0;       ///< W_s
    glm::dvec3 offsetS{0.0};    ///< sum (l_j - x) w_s,j
    double r2S = 0.0;           ///< sum r_j^2 w_s,j
    double momentS = 0.0;       ///< sum |l_j - x|^2 w_s,j
};

/// Per receiver: the sum of the error bounds of the clusters it took (|cut - flat| <= this).
struct CutBound {
    glm::dvec3 irradiance{0.0}; ///< W/m^2
    glm::dvec3 glossy{0.0};     ///< W/(sr m^2) per unit f_s
};

/// Totals over all receivers of one gather.
struct CutStatistics {
    std::uint64_t clusters = 0; ///< inner clusters taken as one light (those with U > 0)
    std::uint64_t skipped = 0;  ///< inner clusters taken with U = 0 (add nothing)
    std::uint64_t leaves = 0;   ///< VALs added exactly
    std::uint64_t visited = 0;  ///< nodes visited (the walk's loop iterations)
};

} // namespace lightskin::gi::gather
