#pragma once
// Double-precision CPU reference of every LightSkin stage (paper sections 3.1-3.3): gather
// (eq. 3-5, 7), renormalisation (eq. 8-11), occlusion (section 3.3, eq. 14), vertex interpolation
// (eq. 12-13), per-pixel shading (eq. 10) and the brute force (eq. 2 with 4 and 5). The formulas
// are compiled from the same source as the shaders (gi/lightskin/shaders/lightskin_math.glsl), so a
// difference between GPU and reference is float rounding, never a second implementation.
//
// Units: world frame, metres; VAL flux in linear RGB W (radiant exitance M = flux / area, see
// lightskin_math.glsl for why the paper's phi acts as M); irradiance W/m^2; radiance W/(sr m^2).
// Slow by design (O(receivers x VALs)); for tests, benchmarks' error measurements and debugging.

#include <lightskin/gi/common/SparsePointSet.h>
#include <lightskin/gi/lightskin/GatherSums.h>
#include <lightskin/gi/common/VirtualAreaLight.h>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <numbers>
#include <span>
#include <vector>

namespace lightskin::gi::reference {

using gather::GatherParameters;
using gather::GatherSums;
using gather::Receiver;

/// World-space receivers of one mesh's sparse points (rigid + uniform-scale world_T_model).
std::vector<Receiver> receiversFromSparsePoints(const SparsePointSet& points, const glm::mat4& world_T_model,
                                                double exponent);

/// eq. 3-5, 7 for every receiver over every VAL; `out` resized to receivers.size().
void gatherInto(std::span<const VirtualAreaLight> lights, std::span<const Receiver> receivers,
                const glm::dvec3& eye, const GatherParameters& parameters, std::vector<GatherSums>& out);

/// An averaged VPL (paper: (L'', l')) with the mean disc r^2 and the occlusion sphere radius.
struct Vpl {
    glm::dvec3 radiance{0.0};   ///< L''
    double r2 = 0.0;            ///< mean r^2 of the VALs behind it, m^2
    glm::dvec3 position{0.0};   ///< l', world metres
    double sphereRadius = 0.0;  ///< S_o radius, metres
};
struct VplPair {
    Vpl diffuse;
    Vpl glossy;
    /// Sparse points: the peak RGB channel of the gathered L'_d (eq. 7, W/m^2), scaled by (1 - o) like
    /// the radiance. Vertices (guard G10): the cap of the shaded diffuse irradiance, the largest of
    /// their contributing sparse points' values; < 0 = no cap (also when a contributing point's is < 0).
    double diffuseCap = -1.0;
};

/// eq. 8-11 per receiver.
void renormaliseInto(std::span<const GatherSums> sums, std::span<const Receiver> receivers, const glm::dvec3& eye,
                     std::vector<VplPair>& out);

/// Section 3.3: per receiver the occlusion amounts o (x = diffuse, y = glossy), in [0, 1], of its
/// S_o spheres by the occluder discs of all receivers (itself excluded).
void occlusionInto(std::span<const Receiver> receivers, std::span<const VplPair> vpls, std::vector<glm::dvec2>& out);

/// L'' *= (1 - o) for both channels.
void applyOcclusion(std::span<const glm::dvec2> occlusion, std::vector<VplPair>& vpls);

/// eq. 12-13: per vertex (world positions/normals) from its 8 neighbours (indices into `sparse`);
/// with `irradianceCap` each vertex's diffuseCap is set (guard G10, LightSkinSettings::vertexIrradianceCap).
/// `sparseBuried` (guard G11): one flag per sparse point, non-zero = under the real surface (e.g. from
/// gi::markBuriedInto); such neighbours get weight 0 unless all of a vertex's are. Empty = none buried.
void interpolateVerticesInto(std::span<const glm::dvec3> vertexPositions, std::span<const glm::dvec3> vertexNormals,
                             std::span<const std::array<std::uint32_t, kVertexNeighbours>> neighbours,
                             std::span<const Receiver> sparseReceivers, std::span<const VplPair> sparse,
                             std::vector<VplPair>& out, bool irradianceCap = true,
                             std::span<const std::uint8_t> sparseBuried = {});

/// Material of a shaded pixel.
struct Surface {
    glm::dvec3 position{0.0};
    glm::dvec3 normal{0.0, 0.0, 1.0};
    glm::dvec3 diffuseAlbedo{0.0}; ///< rho_d
    glm::dvec3 specular{0.0};      ///< f_s
    double exponent = 1.0;         ///< k
};

/// eq. 10: radiance toward `eye` of a surface lit by one VPL pair.
glm::dvec3 shade(const VplPair& vpl, const Surface& surface, const glm::dvec3& eye);

/// Brute force (eq. 2 with 4 and 5): radiance toward `eye` from every VAL, no occlusion.
glm::dvec3 bruteForce(std::span<const VirtualAreaLight> lights, const Surface& surface, const glm::dvec3& eye,
                      const GatherParameters& parameters);

/// Irradiance (W/m^2) at a point from every VAL (eq. 3, 4): sum_j M_j w_j cos(theta_i).
/// nearField: guard G12 (GatherParameters::nearField).
double irradiance(std::span<const VirtualAreaLight> lights, const glm::dvec3& position, const glm::dvec3& normal,
                  int channel = 0, bool nearField = false);

} // namespace lightskin::gi::reference
