#pragma once
// Multi-scale precomputed radiance transfer (Umenhoffer, Szirmay-Kalos et al., "Global Illumination in Games
// with Multi-scale PRT"; issue 16), the third indirect-illumination technique behind gi::IndirectIllumination.
// The virtual content is rigid and placed once (quasi-static): its own light transport is precomputed in
// prepare(), the lighting (the frame's VALs and the scene lights) changes every frame.
//
// Precompute (CPU, Embree for visibility, gi/src/PrtPrecompute.cpp):
//  * exit points = the meshes' vertices (world placement at prepare()). Vertices instead of the paper's
//    texture-atlas texels: the renderer already interpolates per-vertex attributes over the triangles
//    (LightSkin's shading does the same), the meshes have no unique atlas parameterisation (the OBJ/PLY
//    inputs have no or overlapping UVs), and the transfer's size scales with the vertex count, which the
//    scene author controls. Cost: the large-scale term is only as smooth as the tessellation.
//  * entry points: entryPoints samples, uniform by area over all virtual triangles (p(x) = 1 / A_total),
//    each standing for A_total / entryPoints of surface (sec. 7.1, the uniform variant).
//  * transfer T_e[x] (sec. 7.2): irradiance at exit x per unit irradiance at entry e, RGB, by walksPerEntry
//    random walks: the walk starts at e with flux rho(e) A_total / (entryPoints walksPerEntry), leaves by
//    cosine sampling (the Lambertian BRDF's importance sampling), continues at each hit with Russian roulette
//    (survival = max albedo, the flux multiplied by rho / survival); every visited point is a virtual point
//    light connected to each exit point it sees (Embree shadow ray), irradiance phi cos_y cos_x / (pi d^2).
//    Connections shorter than obscuranceDistance are skipped: the medium scale (obscurances) handles them.
//  * clustered PCA (sec. 7.3): k-means of the entry points on (position / scene diagonal, normal), then per
//    cluster the mean map and the D principal maps (Eigen's SVD of the centred transfer rows); per entry its D
//    coordinates.
//  * spectral obscurances per exit point and per entry point (sec. 8), R, G, B separately, obscuranceRays
//    cosine-distributed rays up to obscuranceDistance: W = 1/pi [ int_open cos + int_closed rho(hit) / a cos ],
//    a the area-weighted average albedo (0/0 -> 0). W = 1 when obscuranceDistance = 0.
//  * small scale (sec. 9, AO from displacement/normal maps): off. The mesh loader keeps no normal, height or
//    occlusion textures (core::Material has a diffuse texture only), so there is nothing to evaluate.
//
// Per frame (CPU; prepare's buffers reused, no allocation): the VALs are read back and
//  * E_val(p) = sum_j L_e,j A_j cos_j cos_p / (d^2 + A_j / pi) (the disc form factor of LightSkin eq. 3 and of
//    the paper's sec. 10) at every entry and exit point. Visibility is approximated by the receiving point's
//    spectral obscurance: E_val(p) W(p) (W = 1: no occlusion by the virtual content; the paper multiplies the
//    obscurance with the incoming light the same way);
//  * entry irradiance I_e = W(e) E_val(e) + direct light of the point/spot lights with an exact Embree shadow
//    ray (setLights());
//  * exit irradiance (sec. 10): E(x) = W(x) E_val(x) + sum_c [ (sum_{e in c} I_e) M_c[x]
//    + sum_d (sum_{e in c} I_e w_d^e) B_d^c[x] ], i.e. the first bounce of the room's light directly at the
//    exit points plus the compressed virtual-to-virtual transfer (the scene lights' first bounce is the
//    renderer's direct light, so only their transfer is added);
//  * the target gets rho_d / pi * E per covered pixel: the meshes are re-rasterised with E as a per-vertex
//    attribute (gi/shaders/prt_shade.*), fragments not at the G-buffer's position are discarded.
// Why the CPU for the run time: the work is (entry + exit points) x VALs form factors plus a clusters x
// (D + 1) x exits product, ~20 M multiply-adds for synth-orbit, which one OpenMP loop does in milliseconds;
// on this machine the "GPU" is llvmpipe on the same two cores, so a compute shader would add a dispatch and
// a read-back without adding hardware. The VAL read-back is the price (48 bytes per VAL).
//
// Precompute cache (gi/src/PrtCache.cpp): a binary file <cacheDirectory>/prt-<key>.bin, key = a 64-bit hash
// of the meshes (positions, normals, indices), their placement, materials and the precompute settings. A
// missing, truncated, corrupt or mismatching file logs a warning naming the file and the cause and the data
// are recomputed (and the file rewritten).

#include <lightskin/gi/IndirectIllumination.h>

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
    /// Loads the precompute from the cache or computes it (and writes the cache); sizes the per-frame buffers.
    void prepare(std::span<const MeshInstance> instances) override;
    /// As IndirectIllumination::render(); an empty VAL set gives exactly 0 only without setLights() (the scene
    /// lights' transfer between the objects does not depend on the VALs). The objects must be where prepare()
    /// saw them. Reads the VALs back (count x 48 bytes).
    void render(const ValSetView& lights, std::span<const MeshInstance> instances, const GBufferView& gbuffer,
                const ViewParameters& view, std::uint32_t targetTexture) override;
    /// CPU wall milliseconds of the last render(): "read-back", "entry" (VALs and lights at the entry points),
    /// "exit" (first bounce at the vertices + the compressed transfer), "shade" (issuing the GL pass).
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

private:
    MultiscalePrt();
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::gi
