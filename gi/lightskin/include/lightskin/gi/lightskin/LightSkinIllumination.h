#pragma once
// The LightSkin technique (Lensing & Broll, sections 3-4) on OpenGL 4.5: gather all VALs at the sparse
// points (eq. 3-5, 7; K_cache VALs per pass, summed in fixed blocks of 16 so the image does not depend on
// K_cache), renormalise (eq. 8-11), occlude by the sparse-point discs (3.3), interpolate per vertex
// (eq. 12-13), shade per pixel (eq. 10). Formulas: gi/lightskin/shaders/lightskin_math.glsl, shared with the double
// reference (LightSkinReference.h); VAL flux in W, output radiance W/(sr m^2). Settings::adaptive turns off
// what cannot change the image and, with reuseStatic, reuses the VPLs of static content (exactly, or within
// a stated bound). The stages, the adaptive choices and the reuse guarantees: docs/LIGHTSKIN.md.
// setSettings() and prepare() always force a full computation.

#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gi/common/SparsePointSampler.h>
#include <lightskin/gi/common/SparsePointSet.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

namespace lightskin::gi {


/// How the static-content tolerance mode judges a changed VAL set (see the file comment).
enum class StaticChangeTest {
    Bound,  ///< guaranteed bound over all sparse points; needs ValSetView::keys
    Probes, ///< measured change at every staticProbeStride-th sparse point; any VAL set
};

struct LightSkinSettings {
    /// VALs per gather pass (paper: K_cache = 128). Multiple of 16 (uniform-buffer offset
    /// alignment), at most GL_MAX_UNIFORM_BLOCK_SIZE / 48. Larger: fewer passes, longer loops.
    /// Speed only: the results do not depend on it (fixed 16-VAL summation blocks).
    int kCache = 128;
    bool glossy = true;     ///< the paper's setup 2 (diffuse + glossy)
    bool occlusion = true;  ///< the paper's setup 3 (+ occlusion)
    float cParameter = float(1.0 / (2.0 * std::numbers::pi)); ///< c of c_k = c (k+1), 1/sr
    float epsilonL = 1e-20f;  ///< eps_l of eq. 7
    /// Occluders per occlusion pass (keeps each shader loop far below llvmpipe's ~65k limit).
    int occluderChunk = 4096;
    /// Width of the one-texel-per-sparse-point textures.
    int sparseTextureWidth = 256;
    /// Turn off / cull what cannot change the image (see the file comment).
    bool adaptive = false;
    /// W/m^2: with `adaptive`, VALs whose irradiance upper bound over the receivers' bounding
    /// sphere is below this are dropped (0: only exact culling).
    float valInfluenceCutoff = 0.0f;
    /// With `adaptive`: the kept VALs keep their input order (stream compaction: count, scan,
    /// scatter), so the gather sums and the image are bitwise reproducible. false: the former
    /// atomic append (order, and the results at rounding level ~1e-6, change from run to run);
    /// for measurement (docs/BENCHMARKS.md).
    bool stableCull = true;
    /// Metres: a re-rasterised fragment farther than this (plus 1e-4 of its distance to the
    /// camera) from the G-buffer position is a hidden surface and is discarded.
    float shadingPositionTolerance = 1e-4f;
    /// Gather with the compute-shader variant (shared-memory tiles of 64 VALs, image
    /// load/store) instead of fragment passes; for measurement (see docs/BENCHMARKS.md).
    bool computeGather = false;
    /// VALs per compute dispatch (compute variant; each thread loops over them), rounded down
    /// to a multiple of 64 (one shared-memory tile); clamped to [64, 32768].
    int computeValsPerDispatch = 16384;
    /// Gather with a cut through a VAL tree (ValTree.h): at each sparse point a cluster of VALs
    /// is taken as one light when the bound on the error of doing so is <= valTreeThreshold x the point's
    /// running estimate (gi/lightskin/shaders/val_tree_math.glsl); else its children are examined. 0 = the flat
    /// gather over every VAL (exact; the default). Larger: fewer lights per point, larger error
    /// (docs/BENCHMARKS.md "VAL tree"). Replaces computeGather's and the fragment passes' gather when > 0.
    float valTreeThreshold = 0.0f;
    /// The cut only in frames with at least this many VALs; with fewer the flat gather (exact) runs, being the
    /// cheaper there (gi::configFor's automatic choice; docs/BENCHMARKS.md "VAL tree: where it pays"). 0: always.
    std::uint32_t valTreeMinVals = 0;
    /// Tree gather: walk iterations per thread and dispatch (llvmpipe ends loops after ~65k); [64, 32768].
    int valTreeStepsPerDispatch = 16384;
    /// VAL capacity reserved in prepare(); grows (once, logged) if a frame brings more.
    std::uint32_t valCapacity = 1u << 16;
    /// With `adaptive`: reuse the VPLs of the last full computation for static content (see the
    /// file comment). false: every frame recomputes everything (for measurement).
    bool reuseStatic = true;
    /// With `adaptive` and `reuseStatic`: 0 = exact reuse only; tau > 0 also reuses when the bound on
    /// the change of every sparse point's gathered irradiance is <= tau * the largest gathered
    /// irradiance (needs ValSetView::keys; the glossy channel always needs exact reuse).
    float staticTolerance = 0.0f;
    StaticChangeTest staticChangeTest = StaticChangeTest::Bound;
    /// Probes: every n-th sparse point is a probe (re-gathering them costs ~1/n of the gather).
    int staticProbeStride = 16;
    /// Guard G8 of lightskin_math.glsl: a vertex VPL (eq. 13) is never nearer, in
    /// D = |x - l|^2 + rbar^2, than the nearest VPL of the sparse points it interpolates. false = the
    /// model before it (for measurement, `lightskin bench-realdepth`).
    bool vertexDistanceFloor = true;
    /// Guard G9 of lightskin_math.glsl: eq. 10 and 11 treat an averaged VPL as a sphere of
    /// its spread (the radius of S_o) clipped by the receiver's horizon instead of a point, so a
    /// receiver whose light arrives near its horizon gets a smooth falloff, not 0. Needs the second
    /// moments of the gather (gathered when this or `occlusion` is on). false = point VPLs (the model
    /// before it).
    bool extendedVplHorizon = true;
    /// Guard G10 of lightskin_math.glsl: a pixel's diffuse irradiance is capped at the
    /// largest irradiance its vertices' sparse points gathered (W/m^2, peak RGB channel, times their
    /// unoccluded share), so eq. 11's division by a grazing cos cannot amplify light at the vertex.
    /// false = no cap (the model before it).
    bool vertexIrradianceCap = true;
    /// Guard G11 of lightskin_math.glsl: sparse points more than the depth noise (3 sigma of
    /// the Kinect v1 model) under the real surface of ViewParameters::realDepth get weight 0 in the
    /// vertex interpolation (eq. 12-13); a vertex whose neighbours are all buried keeps the paper's
    /// weights. No effect without a depth map. false = the model before it.
    bool buriedSparsePoints = true;
    /// Guard G12 of lightskin_math.glsl: a VAL nearer than 4 of its radii to a sparse point
    /// is integrated as an area (a 32-gon of its area, clipped by the point's tangent plane, Lambert's
    /// closed form) instead of eq. 3's point-like disc. false = the point model. Off by default: on
    /// llvmpipe it costs ~3x the gather (docs/BENCHMARKS.md "Near-field VALs as areas").
    bool nearFieldArea = false;
};

/// What the adaptive mode chose for the last frame.
struct LightSkinChoice {
    bool glossy = true;
    bool occlusion = true;
    std::uint32_t valsIn = 0;      ///< VALs handed to render()
    std::uint32_t valsGathered = 0; ///< after culling
    /// Static content: this frame reused the VPLs of the last full computation (only shading ran).
    bool reused = false;
    /// Tolerance mode: the change measure of the last check relative to max L'_d (Bound:
    /// sum_j B_j; Probes: max change at the probes); -1 if no check ran this frame.
    float staticChangeBound = -1.0f;
    /// Tree gather (valTreeThreshold > 0): nodes of the VAL tree, and per sparse point the lights taken
    /// (the cut size) and the nodes visited; 0 for the flat gather.
    std::uint32_t valTreeNodes = 0;
    float valTreeCutPerPoint = 0.0f, valTreeVisitedPerPoint = 0.0f;
    /// Wall time of the tree build: the quadtree's GPU passes (GpuValQuadtree, until their 16-byte
    /// read-back), or the BVH's VAL read-back, CPU build and node upload
    float valTreeBuildMs = 0.0f;
    bool valTreeQuadtree = false; ///< the image quadtree, built on the GPU (VALs with pixel keys), else the BVH
    std::string reason;
};

class LightSkinIllumination final : public IndirectIllumination {
public:
    /// Needs a current GL 4.5 context; compiles the shaders. Throws lightskin::Error on bad
    /// settings (kCache not a multiple of 16 or too large for a uniform block).
    static std::unique_ptr<LightSkinIllumination> create(const LightSkinSettings& settings,
                                                         SparsePointProvider provider);
    ~LightSkinIllumination() override;

    std::string_view name() const override { return "lightskin"; }
    Technique technique() const noexcept override { return Technique::LightSkin; }
    TechniqueCapabilities capabilities() const noexcept override;
    void prepare(std::span<const MeshInstance> instances) override;
    void render(const ValSetView& lights, std::span<const MeshInstance> instances, const GBufferView& gbuffer,
                const ViewParameters& view, std::uint32_t targetTexture) override;
    void lastStageTimes(std::vector<gl::StageTime>& out) const override;
    /// With `adaptive`: whether the last frame reused the light of static content, and its change bound.
    TechniqueFrameStatistics lastFrameStatistics() const override;

    const LightSkinSettings& settings() const noexcept;
    /// Changes switches and knobs between frames (kCache is validated like in create()).
    void setSettings(const LightSkinSettings& settings);
    const LightSkinChoice& lastChoice() const noexcept;

    /// The prepared sparse points per instance (in prepare() order) and their offsets into the
    /// global sparse-point numbering used by the readbacks below.
    const std::vector<SparsePointSet>& sparsePoints() const noexcept;
    const std::vector<std::uint32_t>& sparseOffsets() const noexcept;
    const std::vector<std::uint32_t>& vertexOffsets() const noexcept override;

    /// Readbacks for tests (slow; not for per-frame use). Each vector has one entry per sparse
    /// point (or vertex) and four vec4 per entry, in the layout documented in LightSkinIllumination.cpp.
    void readGatherSums(std::vector<glm::vec4>& out) const;   ///< 5 vec4 per point
    void readSparseVpls(std::vector<glm::vec4>& out) const;   ///< 4 vec4 per point (before occlusion)
    void readOcclusion(std::vector<glm::vec4>& out) const;    ///< 1 vec4 per point: x = o_d, y = o_s (unclamped sums)
    void readVertexVpls(std::vector<glm::vec4>& out) const override; ///< 4 vec4 per vertex
    /// The VALs the last full computation gathered (with `adaptive`: those kept by the cull), in
    /// gather order (with `stableCull`: their input order).
    void readGatheredVals(std::vector<VirtualAreaLight>& out) const;

private:
    LightSkinIllumination();
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::gi
