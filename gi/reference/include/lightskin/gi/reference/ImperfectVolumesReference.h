#pragma once
// Double-precision CPU reference of every stage of imperfect volumes (Mavridis & Papaioannou, GRAPP 2011;
// paper 003: L1 SH, grid, point sampling, injection, ray marching, bounces, reconstruction of eq. 4/5), written
// from the paper independently of gi/volumes/shaders/volumes_*.comp, so that the GL tests compare two implementations.
// The model choices the paper leaves open (shared by both): docs/LIGHTSKIN.md, "Imperfect volumes".
// Units: world frame, metres; radiance W/(sr m^2) linear RGB (a VAL's exitant radiance is flux / (pi area));
// irradiance W/m^2. Slow by design, for tests.

#include <lightskin/core/TriangleMesh.h>
#include <lightskin/gi/common/VirtualAreaLight.h>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <vector>

namespace lightskin::gi::reference::volumes {

/// SH coefficients in the order Y_0^0, Y_1^-1 (~y), Y_1^0 (~z), Y_1^1 (~x) (real, orthonormal).
using Sh4 = std::array<double, 4>;

/// The four basis functions at a unit direction.
Sh4 shBasis(const glm::dvec3& direction);
/// Sum of coefficients times basis (eq. 1).
double shEvaluate(const Sh4& coefficients, const glm::dvec3& direction);
/// Projection of max(0, n . w): A_l Y_lm(n) with A_0 = pi, A_1 = 2 pi / 3 (Funk-Hecke).
Sh4 shCosineLobe(const glm::dvec3& normal);
/// Integral of L(w) max(0, n . w) over the sphere for an L1 radiance (eq. 4 without rho / pi).
double shIrradiance(const Sh4& radiance, const glm::dvec3& normal);

/// `count` directions, one per cell of equal solid angle 4 pi / count: round(sqrt(count)) bands
/// in z (band heights proportional to their cell counts), cells evenly spaced in phi, each
/// direction at its cell's centre in z and phi + phiOffset (radians). Deterministic.
std::vector<glm::dvec3> stratifiedDirections(int count, double phiOffset = 0.0);

/// Eq. 3: 4 pi / N sum f(w_j) Y(w_j).
Sh4 projectSh(const std::function<double(const glm::dvec3&)>& f, std::span<const glm::dvec3> directions);

/// A cubic grid of resolution^3 cubic voxels; voxel (i, j, k) spans origin + [i, i+1) s, ...
struct Grid {
    glm::dvec3 origin{0.0}; ///< minimum corner, world metres
    double voxelSize = 1.0; ///< s, metres
    int resolution = 1;     ///< voxels per side

    std::size_t voxelCount() const;
    glm::ivec3 voxelOf(const glm::dvec3& position) const; ///< may lie outside the grid
    bool inside(const glm::ivec3& voxel) const;
    std::size_t index(const glm::ivec3& voxel) const; ///< x fastest
    glm::dvec3 centre(const glm::ivec3& voxel) const;
};

/// A point of the surfaces injected into the volume.
struct SurfacePoint {
    glm::dvec3 position{0.0};
    glm::dvec3 normal{0.0, 0.0, 1.0}; ///< unit
    glm::dvec3 radiance{0.0};         ///< exitant radiance, W/(sr m^2) RGB (if emits)
    glm::dvec3 albedo{0.0};           ///< diffuse rho, for bounces
    bool emits = false;               ///< false: occupancy, normal and albedo only
};

/// A VAL as a point: its exitant radiance flux / (pi area) (VirtualAreaLight.h), albedo `albedo`.
SurfacePoint pointFromVal(const VirtualAreaLight& val, const glm::dvec3& albedo);

/// The 32-bit hash the GPU uses too (PCG output function), so both sample the same points.
std::uint32_t pcgHash(std::uint32_t value);
/// Uniform in [0, 1) from a hash: the top 24 bits / 2^24 (exact in float and double).
double unitFromHash(std::uint32_t hash);

/// Section 3.1: `perTriangle` points on each triangle with density 1/A (u1 = hash(seed ^ 2 id),
/// u2 = hash(seed ^ (2 id + 1)), id = triangle * perTriangle + k; p = (1 - sqrt u1) a +
/// sqrt u1 (1 - u2) b + sqrt u1 u2 c), with the interpolated vertex normal (model -> world by the
/// upper 3x3, renormalised), no radiance, albedo `albedo`.
std::vector<SurfacePoint> sampleTriangles(const TriangleMesh& mesh, const glm::dmat4& world_T_model, int perTriangle,
                                          const glm::dvec3& albedo, std::uint32_t seed);

/// A point or spot light as the renderer models it (render/shaders/shade.frag, its diffuse term).
struct SceneLight {
    glm::dvec3 position{0.0};             ///< world, metres
    glm::dvec3 direction{0.0, 0.0, -1.0}; ///< spot axis, unit
    glm::dvec3 intensity{0.0};            ///< W/sr, RGB
    double cosOuter = -2.0;               ///< spot: cos(cone + falloff); < -1.5: point light
    double cosInner = -1.0;               ///< spot: cos(cone)
};
/// Whether light `index` reaches `position` (a shadow test); empty: always.
using LightVisibility = std::function<bool(std::size_t index, const glm::dvec3& position)>;

/// Direct irradiance (W/m^2, RGB) at a point of normal n: sum_i I_i cone_i max(0, n . l_i) / d_i^2
/// over the visible lights, cone = smoothstep(cosOuter, cosInner, -l . axis) for spots.
glm::dvec3 directIrradiance(const glm::dvec3& position, const glm::dvec3& normal, std::span<const SceneLight> lights,
                            const LightVisibility& visible = {});
/// Section 3.1's "each point carries its direct light": every point emits albedo / pi * E_direct.
void addDirectLight(std::span<SurfacePoint> points, std::span<const SceneLight> lights,
                    const LightVisibility& visible = {});

/// Voxel contents: sums over the injected points.
struct Volume {
    Grid grid;
    std::vector<std::uint32_t> count, emitterCount;
    std::vector<glm::dvec3> normalSum, radianceSum, albedoSum;

    explicit Volume(const Grid& g);
    void inject(std::span<const SurfacePoint> points); ///< points outside the grid are dropped
    bool occupied(std::size_t voxel) const { return count[voxel] > 0; }
    glm::dvec3 normal(std::size_t voxel) const;   ///< unit mean normal, or 0 where normals cancel
    glm::dvec3 radiance(std::size_t voxel) const; ///< mean radiance of the emitting points (direct)
    glm::dvec3 albedo(std::size_t voxel) const;   ///< mean albedo
};

/// Incoming radiance (or visibility) of one voxel: one Sh4 per colour channel.
struct RgbSh {
    std::array<Sh4, 3> channel{};
};

struct MarchSettings {
    double maxDistance = std::numeric_limits<double>::infinity(); ///< metres from the voxel centre
    /// true: ambient occlusion, L = 1 for a ray that leaves the grid or passes maxDistance
    /// unblocked, 0 for a hit; false: L = the hit voxel's exitant radiance (front side), 0 if none.
    bool visibility = false;
};

/// Eq. 3 for one voxel: rays from its centre along `directions`, sampled at sqrt(3)/2 s + k s.
RgbSh gatherVoxel(const Volume& volume, std::span<const glm::dvec3> exitant, const glm::ivec3& voxel,
                  std::span<const glm::dvec3> directions, const MarchSettings& march);

/// Eq. 4/5 at a surface point: the irradiance (W/m^2 per channel; for visibility, pi * AO).
glm::dvec3 reconstructIrradiance(const Volume& volume, std::span<const RgbSh> incoming, const glm::dvec3& position,
                                 const glm::dvec3& normal);

/// The incoming SH of every voxel after `bounces` (>= 1) passes: pass 1 gathers the direct
/// exitant radiance; pass b + 1 gathers direct + albedo / pi * E_b at each occupied voxel (E_b
/// reconstructed at the voxel centre along its normal; 0 where the normal is 0). Visibility
/// ignores bounces.
std::vector<RgbSh> solve(const Volume& volume, std::span<const glm::dvec3> directions, int bounces,
                         const MarchSettings& march);

} // namespace lightskin::gi::reference::volumes
