#pragma once
// Imperfect volumes (Mavridis & Papaioannou, GRAPP 2011), the second indirect-illumination technique
// behind gi::IndirectIllumination: a voxel grid of the virtual triangles' points and the VALs, ray-marched into
// L1 SH per voxel (one or more bounces, or ambient occlusion), reconstructed per G-buffer pixel. Compute shaders
// gi/volumes/shaders/volumes_*; model choices shared with ImperfectVolumesReference.h. Output: rho_d / pi * E in
// W/(sr m^2) (world metres), or AO in [0, 1]. Needs a current GL 4.5 context; GPU memory is sparse (slot maps).
// Stages, sparse memory and its sizes: docs/LIGHTSKIN.md, "Imperfect volumes".

#include <lightskin/gi/common/IndirectIllumination.h>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace lightskin::gi {

/// A scene light for the direct light of the injected mesh points (the paper's section 3.1: each
/// point carries its direct light). The renderer's model (render/shaders/shade.frag): a point or
/// spot light of radiant intensity I, the spot's smoothstep cone, optional cube-map shadows.
/// A light may lie anywhere, inside or outside the volume: its light on a point is analytic.
struct VolumeLight {
    glm::vec3 position{0.0f};               ///< world, metres
    glm::vec3 direction{0.0f, 0.0f, -1.0f}; ///< spot axis, unit, world; ignored for point lights
    glm::vec3 intensity{0.0f};              ///< radiant intensity, W/sr, linear RGB (power / (4 pi))
    float cosOuter = -2.0f;                 ///< spot: cos(cone + falloff); < -1.5: a point light
    float cosInner = -1.0f;                 ///< spot: cos(cone); full intensity inside
    bool castsShadows = false;              ///< look up the shadow cube map (layer 6 * index + face)
};

/// Lights setDirectLights() takes (the renderer's maximum too).
constexpr int kMaxVolumeLights = 4;

struct ImperfectVolumesSettings {
    int resolution = 64;           ///< voxels per side, 1..256 (paper: 64)
    int pointsPerTriangle = 12;    ///< random points per virtual triangle, 0..256 (paper: 12)
    int raysPerVoxel = 100;        ///< stratified directions per voxel, 1..4096 (paper: 100)
    int bounces = 1;               ///< ray-marching passes, 1..4 (1 = one indirect bounce)
    bool ambientOcclusion = false; ///< AO mode: visibility within aoRange instead of radiance
    float aoRange = 0.5f;          ///< metres; rays unblocked this far count as open (AO mode only)
    /// Auto-fit (default): the cube around the virtual content's bounding box grown by `margin`
    /// metres on every side, so the real surfaces near the objects (table, walls) enter the volume.
    bool autoFit = true;
    float margin = 1.0f;     ///< metres, >= 0
    glm::vec3 origin{-1.0f}; ///< fixed grid (autoFit false): minimum corner, world metres
    float size = 2.0f;       ///< fixed grid: edge length, metres (> 0)
    /// Albedo of the real points for bounces. 0: real surfaces re-emit only what the camera saw,
    /// which already holds the room's own interreflections (a nonzero value counts those twice).
    float realAlbedo = 0.0f;
    std::uint32_t seed = 1; ///< of the triangle points (same hash as the reference)
    /// Temporal aliasing (the paper's section 4.1: voxels toggle as points move between them).
    /// jitter: per frame the ray origins move to a different sub-voxel position (a frame hash in
    /// [-1/2, 1/2)^3 voxels) instead of the centres, and the triangle points are re-drawn; with
    /// temporalBlend h > 0 each voxel's SH is (1 - h) * this frame's + h * the previous frame's
    /// (where that voxel was marched in the previous frame too and the grid did not move), an
    /// exponential average over ~1 / (1 - h) frames, so the sampling positions average over the voxel.
    bool jitter = false;
    float temporalBlend = 0.0f; ///< h in [0, 0.95]; 0 = off
    /// Cap on the compact slots (0: as many as one storage buffer holds, see slotCapacity()). Voxels
    /// beyond it are dropped and counted (lastDroppedVoxels()); a cap lets tests provoke that cheaply.
    std::uint32_t maxSlots = 0;
};

/// Throws lightskin::Error naming the field and the allowed range.
void validate(const ImperfectVolumesSettings& settings);

class ImperfectVolumes final : public IndirectIllumination {
public:
    /// Needs a current GL 4.5 context; allocates the volume. Throws lightskin::Error on bad settings.
    static std::unique_ptr<ImperfectVolumes> create(const ImperfectVolumesSettings& settings);
    ~ImperfectVolumes() override;

    std::string_view name() const override { return "imperfect-volumes"; }
    Technique technique() const noexcept override { return Technique::ImperfectVolumes; }
    /// Its mesh points carry the direct light of the scene lights it was created with.
    TechniqueCapabilities capabilities() const noexcept override {
        TechniqueCapabilities c;
        c.sceneLightsAtCreation = true;
        return c;
    }
    /// voxelsDropped: lastDroppedVoxels(), both kinds.
    TechniqueFrameStatistics lastFrameStatistics() const override;
    /// Uploads each mesh's positions, normals and indices (model space) for the point sampling.
    void prepare(std::span<const MeshInstance> instances) override;
    void render(const ValSetView& lights, std::span<const MeshInstance> instances, const GBufferView& gbuffer,
                const ViewParameters& view, std::uint32_t targetTexture) override;
    void lastStageTimes(std::vector<gl::StageTime>& out) const override;

    /// The scene's lights for the direct light of the mesh points, from the next render() on
    /// (copied; lights are static in the world in this project, so call it when the scene loads).
    /// Each mesh point then emits rho_d / pi * sum_i I_i cone_i max(0, n . l_i) / d_i^2 * shadow_i
    /// (W/(sr m^2)); without lights (the default) mesh points only occupy and reflect. Real VAL
    /// points outside the grid are dropped (clipped); lights act from anywhere.
    /// `shadowDistanceCubes`: optional GL name of an R32F cube-map array (6 layers per light, in the
    /// order of `lights`) of the distance in metres from each light to the nearest virtual surface,
    /// as render::Renderer::shadowMapTexture() holds it; 0 = unshadowed. Not owned: it must stay
    /// valid while render() uses it. Throws lightskin::Error for more than kMaxVolumeLights lights.
    void setDirectLights(std::span<const VolumeLight> lights, std::uint32_t shadowDistanceCubes = 0);

    /// The grid of the last render(): minimum corner (world metres) and voxel edge (metres).
    glm::vec3 gridOrigin() const;
    float voxelSize() const;
    /// Read-backs for tests (slow): per voxel (x fastest) the mean normal with w = 1 where occupied,
    /// and the incoming SH of the last pass as three vec4 (r, g, b; coefficients Y00, Y1-1, Y10, Y11;
    /// 0 for voxels that were not ray-marched).
    std::vector<glm::vec4> downloadVoxelNormals() const;
    std::vector<glm::vec4> downloadIncoming() const;
    /// Per voxel the mean direct exitant radiance of its emitting points (W/(sr m^2), rgb; w unused).
    std::vector<glm::vec4> downloadVoxelDirect() const;
    /// Slots of the compact per-voxel storage: every voxel up to 128^3; at 256^3 the 2.8 M that one
    /// storage buffer of 128 MiB holds on llvmpipe (occupied and ray-marched voxels beyond it are dropped).
    std::uint32_t slotCapacity() const;
    /// Occupied and ray-marched voxels of the last render() as requested (may exceed slotCapacity()).
    glm::uvec2 downloadVoxelCounts() const;
    /// Occupied (x) and ray-marched (y) voxels the last render() dropped for want of slots; 0 when the
    /// grid has a slot for every voxel. When any are dropped, render() logs one warning per technique
    /// object naming the counts and the remedy (a smaller resolution); the counters are read back
    /// (8 bytes, a sync) only when the grid has more voxels than slots.
    glm::uvec2 lastDroppedVoxels() const;

private:
    ImperfectVolumes();
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::gi
