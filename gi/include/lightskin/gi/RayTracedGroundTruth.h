#pragma once
// Ground truth for the LightSkin approximations: one-bounce indirect light at receiver points from
// the same VAL discs, with exact ray-traced visibility against the virtual meshes (Embree 3),
// accumulated in double precision. Measures what the occlusion approximation (section 3.3) and the
// sparse interpolation cost.
//
// Each VAL j is a Lambertian disc of radius r = sqrt(a / pi), radiance L_e = phi / (pi a) on its
// normal's side. At a receiver x with normal n_x:
//   E(x) = sum_j  integral over disc j of  L_e,j cos(theta_j) cos(theta_i) / |x - y|^2 V(x, y) dA_y
// (cosines clamped at 0: parts of a disc below the receiver's horizon or seen from behind add
// nothing). Two quadratures (GroundTruthSettings):
//  * stratified (rings x sectors > 1): the disc is cut into rings x sectors cells of equal area
//    (ring boundaries r sqrt(k / rings)), each evaluated at its area-centre with its own shadow ray.
//    Converges to the exact integral; error O(1 / cells) where the integrand is smooth, and about
//    (boundary cells / cells) of a disc's contribution where a shadow edge crosses it.
//  * centre (rings = sectors = 1): the paper's disc form factor, L_e pi r^2 cos(theta_j) cos(theta_i)
//    / (r^2 + d^2) (eq. 3; exact for a coaxial facing disc), times the visibility of the disc centre
//    only: binary, so a half-hidden disc counts fully visible or fully hidden.
// Outgoing radiance toward the viewer: the diffuse part rho_d / pi * E plus the glossy term of
// the LightSkin core, eq. 5 of the paper: f_s c (k + 1) cos^k(gamma) per unit of incident
// L_e cos(theta_j) dA / d^2 (no cos(theta_i) factor; samples below the receiver's horizon add
// nothing), gamma between the mirror direction of the incident light and the view direction, c =
// GroundTruthSettings::glossyC (LightSkinSettings::cParameter, default 1 / (2 pi)). The same model as
// the technique's (lightskin_math.glsl), so LightSkin against this truth measures the sparse
// interpolation and occlusion approximations, not a difference of reflectance models. (Before
// issue 20 this was a normalised Phong lobe f_s (k + 2) / (2 pi) cos^k(gamma) cos(theta_i).)
//
// Shadow rays run from x toward the sample y over t in [eps, 1 - eps] * |y - x| (eps = rayEpsilon,
// relative, so the test scales with the scene from millimetres to kilometres); surfaces nearer
// than that to x or y are ignored (x and y themselves usually lie on surfaces).

#include <lightskin/core/Material.h>
#include <lightskin/core/TriangleMesh.h>
#include <lightskin/gi/VirtualAreaLight.h>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include <memory>
#include <span>

namespace lightskin::gi {

struct GroundTruthSettings {
    int discRings = 8;    ///< >= 1
    int discSectors = 16; ///< >= 1; 1 x 1 = centre mode (see above)
    double rayEpsilon = 1e-4;
    bool visibility = true;               ///< false: no shadow rays (the unoccluded integral)
    int threads = 0;                      ///< receivers are split over this many threads; 0 = hardware concurrency
    double glossyC = 0.15915494309189535; ///< c of eq. 5's c_k = c (k + 1), 1/sr (1 / (2 pi))
};

struct GroundTruthReceiver {
    glm::dvec3 position{0.0};           ///< world, metres
    glm::dvec3 normal{0.0, 0.0, 1.0};   ///< unit, world
    glm::dvec3 toViewer{0.0, 0.0, 1.0}; ///< unit, world: direction of the outgoing radiance
    Material material;
};

struct GroundTruthResult {
    glm::dvec3 irradiance{0.0};           ///< E, W/m^2 (VAL flux units per m^2), with visibility
    glm::dvec3 unoccludedIrradiance{0.0}; ///< the same integral with V = 1
    glm::dvec3 radiance{0.0};             ///< outgoing toward toViewer: diffuse + glossy, with visibility
};

/// The occluding geometry: triangle meshes placed in the world (model space * world_T_model).
struct GroundTruthMesh {
    const TriangleMesh* mesh = nullptr;
    glm::dmat4 world_T_model{1.0};
};

class RayTracedGroundTruth {
public:
    RayTracedGroundTruth();
    ~RayTracedGroundTruth();
    RayTracedGroundTruth(RayTracedGroundTruth&&) noexcept;
    RayTracedGroundTruth& operator=(RayTracedGroundTruth&&) noexcept;

    /// Builds the Embree scene (an empty span gives a scene without occluders). Throws
    /// lightskin::Error when Embree fails or a mesh is invalid.
    static RayTracedGroundTruth create(std::span<const GroundTruthMesh> meshes);

    /// Evaluates every receiver against every VAL (VALs with area <= 0 or non-finite data are skipped).
    /// `out` must have receivers.size() entries. Cost: receivers * VALs * rings * sectors shadow rays.
    void compute(std::span<const VirtualAreaLight> vals, std::span<const GroundTruthReceiver> receivers,
                 std::span<GroundTruthResult> out, const GroundTruthSettings& settings = {}) const;

    /// True when the open segment from `from` to `to` (shortened by rayEpsilon at both ends) hits a triangle.
    bool occluded(const glm::dvec3& from, const glm::dvec3& to, double rayEpsilon = 1e-4) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::gi
