#pragma once
// The LightSkin technique (Lensing & Broll, sections 3-4) on OpenGL 4.5: per frame
//   1. gather (eq. 3-5, 7) of all VALs at every sparse point: fragment passes, one texel per
//      sparse point, K_cache VALs per pass read from a uniform buffer (Listing 1); each pass
//      continues its texel's running sums in fixed blocks of 16 VALs, so the sums (and the
//      image) do not depend on K_cache (gi/shaders/gather_sum_block.glsl);
//   2. renormalisation (eq. 8-11);
//   3. occlusion (section 3.3, eq. 14) by the sparse-point discs of all virtual meshes;
//   4. vertex interpolation (eq. 12-13) from the 8 nearest sparse points (compute pass);
//   5. per-pixel shading (eq. 10): the meshes are re-rasterised, the interpolated per-vertex VPLs
//      arrive per pixel through the rasteriser, and each fragment is shaded with the G-buffer's
//      position, normal and material (fragments whose position differs from the G-buffer's are
//      hidden surfaces and are discarded).
// All formulas come from gi/shaders/lightskin_math.glsl, shared with the double reference
// (LightSkinReference.h). Units: see that file (VAL flux in W; output radiance W/(sr m^2)).
//
// "Model only what a scene requires" (Settings::adaptive): per frame the technique turns off
// what cannot change the image: the glossy channel when no material has f_s (exact), occlusion
// when the scene is one convex object (exact: no sparse point sees another above its horizon),
// and VALs that cannot reach any sparse point (invalid, or the whole receivers' bounding sphere
// behind the VAL's plane: exact up to eps_l; optionally VALs whose irradiance bound is below
// Settings::valInfluenceCutoff: error <= dropped count * cutoff). The choice is logged when it
// changes and readable through lastChoice().

#include <lightskin/gi/IndirectIllumination.h>
#include <lightskin/gi/SparsePointSampler.h>
#include <lightskin/gi/SparsePointSet.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

namespace lightskin::gi {


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
    /// Metres: a re-rasterised fragment farther than this (plus 1e-4 of its distance to the
    /// camera) from the G-buffer position is a hidden surface and is discarded.
    float shadingPositionTolerance = 1e-4f;
    /// Gather with the compute-shader variant (shared-memory tiles of 64 VALs, image
    /// load/store) instead of fragment passes; for measurement (see docs/BENCHMARKS.md).
    bool computeGather = false;
    /// VALs per compute dispatch (compute variant; each thread loops over them), rounded down
    /// to a multiple of 64 (one shared-memory tile); clamped to [64, 32768].
    int computeValsPerDispatch = 16384;
    /// VAL capacity reserved in prepare(); grows (once, logged) if a frame brings more.
    std::uint32_t valCapacity = 1u << 16;
};

/// What the adaptive mode chose for the last frame.
struct LightSkinChoice {
    bool glossy = true;
    bool occlusion = true;
    std::uint32_t valsIn = 0;      ///< VALs handed to render()
    std::uint32_t valsGathered = 0; ///< after culling
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
    void prepare(std::span<const MeshInstance> instances) override;
    void render(const ValSetView& lights, std::span<const MeshInstance> instances, const GBufferView& gbuffer,
                const ViewParameters& view, std::uint32_t targetTexture) override;
    void lastStageTimes(std::vector<gl::StageTime>& out) const override;

    const LightSkinSettings& settings() const noexcept;
    /// Changes switches and knobs between frames (kCache is validated like in create()).
    void setSettings(const LightSkinSettings& settings);
    const LightSkinChoice& lastChoice() const noexcept;

    /// The prepared sparse points per instance (in prepare() order) and their offsets into the
    /// global sparse-point numbering used by the readbacks below.
    const std::vector<SparsePointSet>& sparsePoints() const noexcept;
    const std::vector<std::uint32_t>& sparseOffsets() const noexcept;
    const std::vector<std::uint32_t>& vertexOffsets() const noexcept;

    /// Readbacks for tests (slow; not for per-frame use). Each vector has one entry per sparse
    /// point (or vertex) and four vec4 per entry, in the layout documented in LightSkinIllumination.cpp.
    void readGatherSums(std::vector<glm::vec4>& out) const;   ///< 5 vec4 per point
    void readSparseVpls(std::vector<glm::vec4>& out) const;   ///< 4 vec4 per point (before occlusion)
    void readOcclusion(std::vector<glm::vec4>& out) const;    ///< 1 vec4 per point: x = o_d, y = o_s (unclamped sums)
    void readVertexVpls(std::vector<glm::vec4>& out) const;   ///< 4 vec4 per vertex

private:
    LightSkinIllumination();
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::gi
