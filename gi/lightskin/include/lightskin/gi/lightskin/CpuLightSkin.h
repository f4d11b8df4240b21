#pragma once
// LightSkin (Lensing & Broll, sections 3-4) with stages 0-4 on the CPU: for machines without a GPU,
// where the GL gather on llvmpipe reaches a small fraction of the cores' FMA peak. The gather and occlusion are
// SIMD across sparse points (Google Highway), threads (oneTBB) split points and vertices; the per-pixel shading
// stays the GL path's. Results are bit-for-bit independent of the thread count.
// Units and frames as LightSkinIllumination (world metres, VAL flux W, output radiance W/(sr m^2)). Needs the GL
// context current for upload and shading; per-frame code does not allocate once the VAL capacity has grown to
// the largest set seen. Stages, settings used and ignored, rounding: docs/LIGHTSKIN.md, "The CPU backend".

#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gi/lightskin/LightSkinIllumination.h>
#include <lightskin/gi/common/SparsePointSampler.h>
#include <lightskin/gi/common/SparsePointSet.h>

#include <glm/vec4.hpp>

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace lightskin::gi {

struct CpuLightSkinSettings {
    LightSkinSettings lightSkin; ///< the technique's switches (see the file comment for which apply)
    /// Worker threads for stages 1-4; 0 = all hardware threads (oneTBB's default). Speed only:
    /// the results do not depend on it.
    int threads = 0;
    /// Skip the gather's blocks of 16 VALs x 16 sparse points that lie wholly behind the points
    /// (every cos theta_i <= 0, so every term is exactly 0), and the occlusion's occluders below the
    /// horizon of every point of a vector (every term exactly 0 too). Exact: the results are the same bit
    /// for bit either way; false only to check that (tests) or to measure the saving (benchmarks).
    bool skipHiddenBlocks = true;
};

/// Wall-clock times of the CPU stages of the last render() and what they did (for benchmarks).
struct CpuLightSkinStats {
    std::uint32_t vals = 0;     ///< valid VALs gathered
    std::uint32_t points = 0;   ///< sparse points
    std::uint32_t vertices = 0; ///< vertices interpolated
    bool glossy = false, occlusion = false;
    /// normalisationMs and occlusionMs: ~0 for the flat gather (no cut), whose threads renormalise
    /// their points and sum their occlusion right after gathering them (counted in gatherMs).
    double uploadMs = 0.0, gatherMs = 0.0, normalisationMs = 0.0, occlusionMs = 0.0, interpolationMs = 0.0;
    double shadingMs = 0.0; ///< CPU time to issue the GL shading pass (its GPU time: lastStageTimes())
    /// Process CPU time (all threads) of the gather, the occlusion stage and stages 0-4 of
    /// computeVpls(): under load from other processes wall time overstates the work, CPU time does not.
    /// For the flat gather occlusionCpuMs is its threads' time in the occlusion kernel (steady clock per
    /// group of 16 points, as a CPU clock read there would cost ~1/10 of what it measures: the CPU time
    /// unless another process took the core meanwhile, so take the minimum over frames), and gatherCpuMs
    /// their region's CPU time less that (gather, renormalisation, occlusion set-up; the minimum over
    /// frames of gatherCpuMs + occlusionCpuMs less that of occlusionCpuMs is robust to such frames).
    double gatherCpuMs = 0.0, occlusionCpuMs = 0.0, stagesCpuMs = 0.0;
    /// Stages 0-4 on idle cores, from thread CPU clocks alone: the calling thread's CPU time, with
    /// its share of each parallel region replaced by the busiest thread's (CLOCK_THREAD_CPUTIME_ID per
    /// task), i.e. serial work + the critical thread of every region: the wall time on the machine's
    /// threads when nothing else runs (fork/join latency excluded), the regions split as they were
    /// scheduled. It does not count waiting for a core; a region that ran on one thread because the
    /// other was not scheduled in time (load) counts whole. The gather with a cut: its own threads
    /// are not counted (criticalPathCpuMs then understates).
    double criticalPathCpuMs = 0.0;
    std::string simdTarget;          ///< the instruction set the runtime dispatch chose, e.g. "AVX3"
    double valTreeCutPerPoint = 0.0; ///< valTreeThreshold > 0: lights taken per sparse point
    bool valTreeQuadtree = false;    ///< the cut went through the image quadtree (CpuValPixelKeys), else the BVH
    /// Fraction of the gather's (block of 16 VALs, sparse point) pairs skipped as wholly hidden (the points
    /// decide in vectors of the dispatched width: 16 with AVX-512).
    double gatherBlocksSkipped = 0.0;
    /// Fraction of the occlusion's (occluder, sparse point) pairs skipped as below every horizon of a vector.
    double occlusionPairsSkipped = 0.0;
};

class CpuLightSkin final : public IndirectIllumination, public CpuValTechnique {
public:
    /// Needs a current GL 4.5 context (the shading pass). Throws lightskin::Error on bad settings.
    static std::unique_ptr<CpuLightSkin> create(const CpuLightSkinSettings& settings, SparsePointProvider provider);
    ~CpuLightSkin() override;

    std::string_view name() const override { return "lightskin-cpu"; }
    Technique technique() const noexcept override { return Technique::LightSkin; }
    Backend backend() const noexcept override { return Backend::Cpu; }
    TechniqueCapabilities capabilities() const noexcept override;
    CpuValTechnique* cpuValInput() noexcept override { return this; }
    int threads() const noexcept override;
    void prepare(std::span<const MeshInstance> instances) override;
    void render(const ValSetView& lights, std::span<const MeshInstance> instances, const GBufferView& gbuffer,
                const ViewParameters& view, std::uint32_t targetTexture) override;
    /// render() with the VALs already on the CPU (e.g. gi::CpuValGenerator's; not kept after the
    /// call): no read-back of a GL buffer. Invalid VALs (area <= 0 or NaN) are skipped as in render().
    /// `pixels`: the VALs' image pixels, if any (CpuValPixelKeys).
    void renderCpuVals(std::span<const VirtualAreaLight> lights, std::span<const MeshInstance> instances,
                       const GBufferView& gbuffer, const ViewParameters& view, std::uint32_t targetTexture,
                       const CpuValPixelKeys& pixels = {}) override;
    /// upload, gather, normalisation, occlusion, interpolation: CPU wall clock; shading: GL timer.
    void lastStageTimes(std::vector<gl::StageTime>& out) const override;

    const CpuLightSkinSettings& settings() const noexcept;
    void setSettings(const CpuLightSkinSettings& settings);
    const CpuLightSkinStats& lastStats() const noexcept;

    /// Stages 1-4 on VALs already on the CPU (no GL call): what render() does after reading the
    /// VALs back and before writing the vertex VPLs to the GL buffer. For benchmarks and tests;
    /// needs prepare() (which needs a GL context for the buffers it creates). `pixels` as in renderCpuVals();
    /// `realDepth` (its CPU map, `data`) drives guard G11 as ViewParameters::realDepth does in render(); none = no
    /// point buried.
    void computeVpls(std::span<const VirtualAreaLight> lights, std::span<const MeshInstance> instances,
                     const glm::vec3& cameraPositionWorld, const CpuValPixelKeys& pixels = {},
                     const RealDepthView& realDepth = {}) override;

    /// The second half of renderCpuVals(): uploads the per-vertex VPLs of the last computeVpls() and runs the
    /// per-pixel shading pass into `targetTexture` (needs the GL context). computeVpls() may run on another
    /// thread (no GL) for a later frame only after this call has returned (mr::FramePipeline's GI ahead).
    void shadeVpls(std::span<const MeshInstance> instances, const GBufferView& gbuffer, const ViewParameters& view,
                   std::uint32_t targetTexture) override;

    /// The same readbacks, in the same layouts, as LightSkinIllumination's (see its header; cheap
    /// here: the data are on the CPU).
    void readGatherSums(std::vector<glm::vec4>& out) const; ///< 5 vec4 per point, eps_l terms included
    void readSparseVpls(std::vector<glm::vec4>& out) const; ///< 4 vec4 per point (before occlusion)
    void readOcclusion(std::vector<glm::vec4>& out) const;  ///< 1 vec4 per point: x = o_d, y = o_s (unclamped)
    void readVertexVpls(std::vector<glm::vec4>& out) const override; ///< 4 vec4 per vertex
    const std::vector<std::uint32_t>& vertexOffsets() const noexcept override;

private:
    CpuLightSkin();
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// The instruction set Highway's runtime dispatch selects on this CPU (e.g. "AVX3", "AVX2").
std::string cpuSimdTarget();
/// For benchmarks: this thread's FMA rate at the dispatched instruction set, GFLOP per CPU-second
/// (12 independent FMA chains, 2 flops per FMA lane, as bench/PeakFlopsBenchmark.cpp), measured
/// over about `milliseconds` of CPU time. Under load from other processes CPU time stays fair.
double cpuFmaPeakGflops(double milliseconds = 50.0);
/// For tests: the gather's Phong lobe cos^k (guard G3 of lightskin_math.glsl, the polynomial
/// log2/exp2 of the dispatched kernels), out[i] for c = cosGamma[i] and k = exponent[i] >= 1:
/// 0 where c <= 0 or k ln c < -80, c clamped to [1e-30, 1]. The spans have equal sizes.
void cpuLobePow(std::span<const float> cosGamma, std::span<const float> exponent, std::span<float> out);
/// The instruction sets this build has kernels for and this CPU supports, best first.
std::vector<std::string> cpuSimdTargets();
/// For benchmarks: makes the dispatch use only `name` (one of cpuSimdTargets(); "" = the best
/// again). Process-wide, between frames. Throws lightskin::Error for a name not in the list.
void setCpuSimdTarget(const std::string& name);

} // namespace lightskin::gi
