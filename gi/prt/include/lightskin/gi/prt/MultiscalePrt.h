#pragma once
// Multi-scale precomputed radiance transfer (Umenhoffer, Szirmay-Kalos et al., "Global Illumination in Games with
// Multi-scale PRT"), the third indirect-illumination technique behind gi::IndirectIllumination. The
// virtual content is rigid and placed once: its own multi-bounce transfer (entry points -> mesh vertices, random
// walks with Embree visibility, compressed by clustered PCA) and spectral obscurances are precomputed in prepare()
// and cached on disk (a bad cache file is recomputed with a warning naming it); per frame the VALs' and the scene
// lights' irradiance at the entry points and the VALs' at gather points among the exits (interpolated to the
// others) is evaluated on the CPU (on llvmpipe a compute shader adds no hardware) and the meshes are
// re-rasterised with it. World metres; output rho_d / pi * E in W/(sr m^2). Needs a
// current GL 4.5 context; per-frame code reuses prepare()'s buffers. Precompute, per-frame formulas, cache key:
// docs/LIGHTSKIN.md, "Multi-scale PRT".
//
// Small scale (paper sec. 9 and 10): per pixel the indirect light is multiplied by an ambient-occlusion factor S of
// the surface detail the mesh does not model, from the instance's Material (the mesh loader keeps glTF's
// occlusionTexture and normalTexture, OBJ's norm); the renderer's direct light is never multiplied. Per instance:
// - an occlusion map: S = 1 + occlusionStrength (R - 1), the glTF definition (it is what the author baked);
// - else a normal map: S = (1 + cos alpha) / 2, alpha the angle between the mapped normal and the mean surface's
//   normal (cos alpha = the normalised tangent-space z after glTF's xy scale). This is the paper's W(alpha, gamma,
//   h) = (1 + h cos alpha + (1 - h) cos gamma) / 2 at h = 1 (the detail's top, its horizon the mean surface), and
//   exact there: the cosine-weighted fraction of the tilted normal's hemisphere above the mean plane. The h < 1
//   term needs a height map and the cone angle gamma of cone stepping (a cone map), which the inputs do not
//   carry, so points in a groove are taken as open as the top: S errs toward 1 (too little occlusion). A flat
//   normal map gives S = 1;
// - else S = 1 (off); also for a mesh without texture coordinates (logged).
// An occlusion map wins over a normal map of the same material: both describe the same detail, and multiplying
// both would count its occlusion twice. S does not double-count the medium scale (the spectral obscurances W) in
// the paper's sense of separating the scales by distance: W is traced against the mesh geometry from an offset
// point on the mean surface over [epsilon, obscuranceDistance], so it cannot see detail that exists only in the
// textures, and S covers only that detail (shorter than the mesh's edges, far below obscuranceDistance). The
// contract on the asset: an occlusion map must hold the detail's own occlusion (as a baked normal map's high- vs
// low-poly difference), not occlusion by the mesh's own large shapes, which W and the transfer already contain.
// S multiplies E = W E_val + transfer as the paper multiplies its three textures: the product treats the detail's
// and the mesh's occlusion as independent.

#include <lightskin/gi/common/IndirectIllumination.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace lightskin::gi {

struct MultiscalePrtSettings {
    int entryPoints = 512;           ///< entry points on all virtual meshes, 1..65536
    int walksPerEntry = 64;          ///< random walks per entry point, 1..65536
    int maxBounces = 8;              ///< path vertices per walk (after the entry) before it stops, 0..64
    int clusters = 16;               ///< k-means clusters of entry points, 1..entryPoints
    int basisVectors = 8;            ///< D, principal maps per cluster, 0..64 (0 = the cluster means only)
    float obscuranceDistance = 0.0f; ///< metres: medium/large threshold; 0 = obscurances off (W = 1)
    int obscuranceRays = 64;         ///< rays per point for the obscurances, 1..4096
    /// Connections from a walk's point to an exit point closer than this (metres) are dropped when
    /// obscuranceDistance is 0: the 1/d^2 kernel of the virtual point lights is unbounded near contact.
    float minConnectionDistance = 1e-3f;
    std::uint32_t seed = 1;
    std::filesystem::path cacheDirectory; ///< empty = no cache (always precompute)
    bool keepUncompressed = false;        ///< keep the entry x exit transfer (tests; entries x exits x 3 floats)
    /// Entry-point density (sec. 7.1). Uniform by area (the default) when `entryLightPoints` is empty or
    /// `entryLightFraction` is 0; else the mixture (1 - f) uniform + f d(e), d(e) the paper's density of first
    /// hits from test points where the light is expected: sum_m cos(theta_e) / |Y_m - e|^2 v(Y_m, e),
    /// evaluated with Embree visibility at each triangle's centroid (piecewise constant per triangle, so that
    /// the pdf is known exactly). The transfer divides by that pdf, so it stays unbiased for any lighting while
    /// f < 1; more entries land where the test points shine, fewer where the lighting will rarely arrive.
    std::vector<glm::vec3> entryLightPoints; ///< world metres (e.g. above the objects: the room's upper half)
    float entryLightFraction = 0.0f;         ///< f, 0..0.99 (0 = uniform; f < 1 keeps the pdf positive)
    /// Per frame, not part of the cache key: the VALs' first bounce is evaluated exactly at this many exit
    /// points (farthest-point sampling in position and normal, every instance at least one) and interpolated
    /// to the others, where evaluating all VALs at every vertex cost most of the frame (docs/BENCHMARKS.md,
    /// "Multi-scale PRT"). 0, or at least as many as there are exits, = every exit point exactly.
    int directGatherPoints = 1024;
    /// Gather points each exit interpolates (inverse squared distance, same instance, normals within 30
    /// degrees; an exit with none becomes a gather point itself), 1..16.
    int directNeighbours = 4;
};

/// Throws lightskin::Error naming the field and the allowed range.
void validate(const MultiscalePrtSettings& settings);

/// A point or spot light for the entry points' direct light (radiant intensity power / (4 pi) W/sr).
struct PrtLight {
    glm::vec3 position{0.0f};               ///< world, metres
    glm::vec3 power{0.0f};                  ///< W, linear RGB
    glm::vec3 direction{0.0f, 0.0f, -1.0f}; ///< spot: unit, world
    float cosOuter = -2.0f;                 ///< spot: cos(cone + falloff); < -1 for a point light
    float cosInner = -2.0f;                 ///< spot: cos(cone) (smoothstep between, as render/shaders/shade.frag)
};

/// The precomputed transfer, world frame. Exit point x of instance m is vertex x - exitOffsets[m] of its mesh.
struct PrtData {
    std::uint64_t key = 0;
    std::vector<std::uint32_t> exitOffsets; ///< per instance, first exit point; back() = exit count
    std::vector<glm::vec3> exitPositions, exitNormals;
    std::vector<glm::vec3> exitObscurance; ///< W per exit point, RGB
    std::vector<glm::vec3> entryPositions, entryNormals;
    std::vector<glm::vec3> entryObscurance;
    std::vector<std::uint32_t> entryCluster;
    int basisVectors = 0; ///< D actually stored (<= settings.basisVectors, capped by cluster sizes)
    std::uint32_t clusterCount = 0;
    /// Per cluster c: mean map at clusterMaps[c (D + 1) 3 X ...] followed by its D basis maps; a map is
    /// 3 X floats, channel-major (all red, then green, then blue), X = exit count.
    std::vector<float> clusterMaps;
    std::vector<float> entryWeights;   ///< per entry, D coordinates in its cluster's basis
    std::vector<float> singularValues; ///< per cluster, min(n_c, 3 X) values, descending (zero padded to D)
    std::vector<std::uint32_t> singularValueOffsets; ///< per cluster, first value; back() = total
    std::vector<float> uncompressed;                 ///< keepUncompressed: entry-major, one 3 X map per entry
    double precomputeSeconds = 0.0;                  ///< wall time of the precompute (0 when loaded from the cache)

    std::size_t exitCount() const noexcept { return exitPositions.size(); }
    std::size_t entryCount() const noexcept { return entryPositions.size(); }
    std::size_t byteSize() const noexcept;
};

/// The precompute of the header comment. Instances need `mesh`, `world_T_model`, `material` (not `gpu`).
/// Throws lightskin::Error on invalid meshes or settings.
PrtData precomputePrt(std::span<const MeshInstance> instances, const MultiscalePrtSettings& settings);
/// The cache key of instances + settings (what precomputePrt's result depends on).
std::uint64_t prtCacheKey(std::span<const MeshInstance> instances, const MultiscalePrtSettings& settings);

/// Writes `data` to `file` (a temporary file renamed into place, so a crash leaves no half-written cache).
/// Throws lightskin::Error naming the file on I/O errors.
void savePrtCache(const PrtData& data, const std::filesystem::path& file);
/// Reads a cache file. Returns false (and sets `reason`) when the file is missing, truncated, corrupt or holds
/// another key; never throws on bad bytes.
bool loadPrtCache(const std::filesystem::path& file, std::uint64_t expectedKey, PrtData& out, std::string& reason);

/// The transfer of entry e reconstructed from the PCA: 3 X floats, channel-major.
void reconstructTransferInto(const PrtData& data, std::size_t entry, std::span<float> out);

/// The per-frame CPU part. `vals` world VALs; `entryIrradiance` (entries, RGB W/m^2) and `exitIrradiance`
/// (exits, RGB W/m^2) are outputs sized by the caller. No allocation.
void prtEntryIrradianceInto(const PrtData& data, std::span<const VirtualAreaLight> vals,
                            std::span<glm::vec3> entryIrradiance);
void prtExitIrradianceInto(const PrtData& data, std::span<const VirtualAreaLight> vals,
                           std::span<const glm::vec3> entryIrradiance, std::span<glm::vec3> exitIrradiance);

/// Where the per-frame first bounce of the VALs is evaluated (MultiscalePrtSettings::directGatherPoints) and
/// how each exit point interpolates it. A gather point g keeps per channel the irradiance vector V_g of the VALs
/// above its tangent plane (E(g) = n_g . V_g); an exit x gets sum_i w_i max(0, n_x . V_gi), a convex
/// combination, so that where the normals agree (a plane) its error is at most the largest difference between
/// its irradiance and that of the gather points it uses, and a normal that differs is followed to first order.
struct PrtGatherPlan {
    std::vector<std::uint32_t> points; ///< exit indices evaluated exactly
    int neighbours = 0;                ///< k: slots per exit
    /// Per exit x, slots [x k, (x + 1) k): an index into `points` and its weight (weights sum to 1; unused
    /// slots have weight 0 and index 0).
    std::vector<std::uint32_t> slot;
    std::vector<float> weight;
    bool exact() const noexcept { return neighbours == 0; } ///< every exit is a gather point
};

/// Builds the plan for `gatherPoints` and `neighbours` (0 gather points, or at least the exit count: exact).
/// Deterministic; O(exits x gather points).
PrtGatherPlan planPrtGather(const PrtData& data, int gatherPoints, int neighbours);

/// prtExitIrradianceInto() with the VALs evaluated at plan.points only (into `gathered`, caller-sized: three
/// irradiance vectors, red, green, blue, per gather point, W/m^2) and interpolated by the plan. No allocation.
void prtExitIrradianceInto(const PrtData& data, const PrtGatherPlan& plan, std::span<const VirtualAreaLight> vals,
                           std::span<const glm::vec3> entryIrradiance, std::span<glm::vec3> gathered,
                           std::span<glm::vec3> exitIrradiance);

/// What MultiscalePrt::prepare() cost, for reports (`lightskin replay`'s report.md / report.json).
struct PrtPrepareStats {
    bool loadedFromCache = false;
    double prepareSeconds = 0.0;       ///< wall time of prepare(): Embree scene + cache load, or precompute + write
    double precomputeSeconds = 0.0;    ///< wall time of the precompute alone; 0 when loaded from the cache
    std::size_t memoryBytes = 0;       ///< PrtData::byteSize() of the transfer kept for the frames
    std::uintmax_t cacheFileBytes = 0; ///< size of the cache file after prepare(); 0 without a cache (or unwritten)
    std::filesystem::path cacheFile;   ///< empty without a cache directory
};

class MultiscalePrt final : public IndirectIllumination {
public:
    /// Needs a current GL 4.5 context (builds the shading program). Throws lightskin::Error on bad settings.
    static std::unique_ptr<MultiscalePrt> create(const MultiscalePrtSettings& settings);
    ~MultiscalePrt() override;

    std::string_view name() const override { return "multiscale-prt"; }
    Technique technique() const noexcept override { return Technique::MultiscalePrt; }
    /// Every stage of lastStageTimes() is a CPU time.
    TechniqueCapabilities capabilities() const noexcept override;
    /// Loads the precompute from the cache or computes it (and writes the cache); sizes the per-frame buffers.
    void prepare(std::span<const MeshInstance> instances) override;
    /// As IndirectIllumination::render(); an empty VAL set gives exactly 0 only without setLights() (the scene
    /// lights' transfer between the objects does not depend on the VALs). The objects must be where prepare()
    /// saw them. Reads the VALs back (count x 48 bytes).
    void render(const ValSetView& lights, std::span<const MeshInstance> instances, const GBufferView& gbuffer,
                const ViewParameters& view, std::uint32_t targetTexture) override;
    /// CPU wall milliseconds of the last render(): "read-back", "entry" (VALs at the entry points), "lights" (the scene
    /// lights at the entry points, Embree shadow rays), "exit" (first bounce at the gather points, interpolated to the
    /// vertices, + the compressed transfer), "shade" (issuing the GL pass).
    void lastStageTimes(std::vector<gl::StageTime>& out) const override;

    /// The scene's point/spot lights (their direct light at the entry points, with Embree shadows). Copied.
    void setLights(std::span<const PrtLight> lights);

    const PrtData& data() const;
    bool loadedFromCache() const;
    std::filesystem::path cacheFile() const; ///< empty without a cache directory
    /// The last prepare()'s cost (default values before the first).
    PrtPrepareStats lastPrepareStats() const;
    /// Per-vertex exit irradiance of the last render() (W/m^2, RGB), exitOffsets order.
    std::span<const glm::vec3> lastExitIrradiance() const;
    /// Where prepare() put the per-frame gather points (MultiscalePrtSettings::directGatherPoints).
    const PrtGatherPlan& gatherPlan() const;

private:
    MultiscalePrt();
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::gi
