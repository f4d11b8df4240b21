// gi::CpuLightSkin against both double references (gi::reference and the independent
// PaperReference, LightSkinComparison.h) and the GL path, stage by stage, on
// the GL tests' scenes (the paper's three setups, the numerical extremes); bit-for-bit
// independence of the thread count; the empty VAL set.
//
// Tolerances against the reference: those of LightSkinGLTest.cpp (derivation at its top), which
// the CPU backend meets for the same reasons: its gather sums the same float terms in the same
// fixed 16-VAL blocks (CpuGatherKernels.h); per term it adds the error of the reciprocal square
// root after one Newton step (~1e-7 relative, below float's 6e-8 x a few operations already in
// the budget) and of Highway's log/exp (a few ulp of cos^k, i.e. the 2.4e-7 k term of the glossy
// budget). Renormalisation, occlusion targets and interpolation run in double from the float
// sums, so they only propagate the gather's error (GL rounds them in float on top).
// Against the GL path: both are within tolerance t of the same reference, so |cpu - gl| <= 2 t
// (the tolerances below are the reference ones doubled).
#include "CarriesTheLight.h"
#include "common/GatherTestScenes.h"
#include "GlTestEnvironment.h"
#include "common/GpuRig.h"
#include "LightSkinComparison.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/SimdTarget.h>
#include <lightskin/gi/lightskin/CpuLightSkin.h>
#include <lightskin/gi/lightskin/LightSkinIllumination.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace lightskin::test {
namespace {

/// The last of `frames` frames of one technique (frames > 1: the gather's layout from the earlier
/// frames' timings, CpuLightSkin.cpp planLayout()).
GpuRun runCpu(Scene& scene, const gi::LightSkinSettings& settings, int threads = 0, int frames = 1) {
    scene.upload();
    gi::CpuLightSkinSettings cpuSettings;
    cpuSettings.lightSkin = settings;
    cpuSettings.threads = threads;
    auto technique = gi::CpuLightSkin::create(cpuSettings, scene.provider());
    technique->prepare(scene.instances);
    for (int frame = 1; frame < frames; ++frame) renderAndRead(scene, *technique);
    return renderAndRead(scene, *technique);
}

GpuRun runGl(Scene& scene, const gi::LightSkinSettings& settings) {
    scene.upload();
    auto technique = gi::LightSkinIllumination::create(settings, scene.provider());
    technique->prepare(scene.instances);
    return renderAndRead(scene, *technique);
}

double maxExponent(const Scene& scene) {
    double k = 1.0;
    for (const gi::MeshInstance& i : scene.instances) k = std::max(k, double(i.material.specularExponent));
    return k;
}

/// CPU against GL with twice compareStages' / comparePixels' tolerances (see the file comment).
void compareBackends(const GpuRun& cpu, const GpuRun& gl, const PaperSetup& setup, double exponent, double pixelRel) {
    ASSERT_EQ(cpu.gather.size(), gl.gather.size());
    ASSERT_EQ(cpu.vertex.size(), gl.vertex.size());
    ASSERT_EQ(cpu.image.size(), gl.image.size());
    const double glossyRel = 2.0 * (2e-4 + 2.4e-7 * exponent);
    Comparison irradiance("CPU vs GL: L'_d", 4e-4, 2e-4), glossy("CPU vs GL: L'_s", glossyRel, 2e-4),
        weights("CPU vs GL: W and sum r^2 w", glossyRel, 2e-4), offsets("CPU vs GL: sum (l - x) w", glossyRel, 2e-4),
        moments("CPU vs GL: moments", 4e-4, 2e-4);
    for (std::size_t i = 0; i < cpu.gather.size(); i += 5) {
        const glm::vec4* c = &cpu.gather[i];
        const glm::vec4* g = &gl.gather[i];
        for (int ch = 0; ch < 3; ++ch) {
            irradiance.add(c[0][ch], g[0][ch]);
            offsets.add(c[1][ch], g[1][ch]);
            glossy.add(c[2][ch], g[2][ch]);
            offsets.add(c[3][ch], g[3][ch]);
            if (setup.occlusion) moments.add(c[4][ch], g[4][ch]);
        }
        for (int slot : {0, 1, 2, 3}) weights.add(c[slot].w, g[slot].w);
        if (setup.occlusion && setup.glossy) moments.add(c[4].w, g[4].w);
    }
    irradiance.check();
    glossy.check();
    weights.check();
    offsets.check();
    moments.check();
    Comparison vplRadiance("CPU vs GL: L''", 2.0 * (2e-3 + 2.4e-7 * exponent), 2e-4);
    for (std::size_t i = 0; i < cpu.vpls.size(); i += 4)
        for (int ch = 0; ch < 3; ++ch) {
            vplRadiance.add(cpu.vpls[i][ch], gl.vpls[i][ch]);
            vplRadiance.add(cpu.vpls[i + 2][ch], gl.vpls[i + 2][ch]);
        }
    vplRadiance.check();
    if (setup.occlusion) {
        // each within 2e-3 (absolute, o clamped to [0, 1]) of the reference
        double worst = 0.0;
        for (std::size_t i = 0; i < cpu.occlusion.size(); ++i)
            for (int ch = 0; ch < (setup.glossy ? 2 : 1); ++ch)
                worst = std::max(worst, std::abs(std::clamp(double(cpu.occlusion[i][ch]), 0.0, 1.0) -
                                                 std::clamp(double(gl.occlusion[i][ch]), 0.0, 1.0)));
        EXPECT_LE(worst, 4e-3) << "CPU vs GL: occlusion amounts";
    }
    Comparison vertex("CPU vs GL: vertex VPL radiance", 2.0 * (3e-3 + 2.4e-7 * exponent), 2e-4);
    for (std::size_t v = 0; v < cpu.vertex.size(); v += 4)
        for (int ch = 0; ch < 3; ++ch) {
            vertex.add(cpu.vertex[v][ch], gl.vertex[v][ch]);
            vertex.add(cpu.vertex[v + 2][ch], gl.vertex[v + 2][ch]);
        }
    vertex.check();
    // same G-buffer and shading pass: pixels differ only through the vertex VPLs
    Comparison pixels("CPU vs GL: pixel radiance", 2.0 * pixelRel, 2e-3);
    for (std::size_t i = 0; i < cpu.image.size(); ++i) {
        if (gl.gbufferPosition[i].w == 0.0f) {
            EXPECT_EQ(cpu.image[i], glm::vec4(0.0f)) << "uncovered pixels must be 0";
            continue;
        }
        for (int ch = 0; ch < 3; ++ch) pixels.add(cpu.image[i][ch], gl.image[i][ch]);
    }
    pixels.check();
}

// ---- the paper's setups ---------------------------------------------------------------------
class CpuLightSkinSetupGLTest : public GlTest, public ::testing::WithParamInterface<PaperSetup> {};

TEST_P(CpuLightSkinSetupGLTest, EveryStageMatchesTheDoubleReference) {
    const PaperSetup setup = GetParam();
    Scene scene = sphereOverFloor();
    gi::LightSkinSettings settings;
    settings.glossy = setup.glossy;
    settings.occlusion = setup.occlusion;
    settings.nearFieldArea = setup.nearField;
    checkSetup(setup, scene, runCpu(scene, settings));
}

TEST_P(CpuLightSkinSetupGLTest, MatchesTheGlPath) {
    const PaperSetup setup = GetParam();
    Scene scene = sphereOverFloor();
    gi::LightSkinSettings settings;
    settings.glossy = setup.glossy;
    settings.occlusion = setup.occlusion;
    settings.nearFieldArea = setup.nearField;
    const GpuRun cpu = runCpu(scene, settings);
    const GpuRun gl = runGl(scene, settings);
    compareBackends(cpu, gl, setup, maxExponent(scene), 3e-3);
}

// The runtime dispatch: every instruction set this CPU supports (AVX-512, AVX2, SSE4, ... down to
// scalar) meets the same reference tolerances, so machines without AVX-512 get correct results.
TEST_P(CpuLightSkinSetupGLTest, EveryInstructionSetMatchesTheDoubleReference) {
    const PaperSetup setup = GetParam();
    Scene scene = sphereOverFloor();
    gi::LightSkinSettings settings;
    settings.glossy = setup.glossy;
    settings.occlusion = setup.occlusion;
    settings.nearFieldArea = setup.nearField;
    const ReferenceRun r = runReference(scene, setup);
    const std::vector<std::string> targets = gi::cpuSimdTargets();
    ASSERT_FALSE(targets.empty());
    for (const std::string& target : targets) {
        SCOPED_TRACE("instruction set " + target);
        gi::setCpuSimdTarget(target);
        EXPECT_EQ(gi::cpuSimdTarget(), target);
        const GpuRun cpu = runCpu(scene, settings);
        ReferenceRun adopted = r;
        if (setup.occlusion) {
            EXPECT_LE(adoptUnresolvedOcclusion(adopted, cpu), adopted.receivers.size() / 50)
                << "points with an unresolved, point-like S_o";
        }
        compareStages(cpu, adopted, setup);
    }
    gi::setCpuSimdTarget("");
    EXPECT_EQ(gi::cpuSimdTarget(), targets.front());
    EXPECT_THROW(gi::setCpuSimdTarget("NO_SUCH_TARGET"), Error);
}

// The interpolation takes eq. 12's weights from model space when a mesh's transform is a similarity
// (CpuLightSkin.cpp, isSimilarity()); the paper setups' rotated sphere and identity floor run that
// path. A non-uniform scale changes the distance ratios and the normals' angles, so the weights
// must come from world space: the sphere squashed to an ellipsoid must still meet every stage's
// reference tolerance (the reference computes its weights in world space, LightSkinComparison.h).
using CpuLightSkinTransformGLTest = GlTest;

TEST_F(CpuLightSkinTransformGLTest, ANonUniformlyScaledMeshMatchesTheDoubleReference) {
    Scene scene = sphereOverFloor();
    scene.instances[0].world_T_model = glm::scale(scene.instances[0].world_T_model, {1.3f, 0.7f, 1.0f});
    const PaperSetup setup{"occlusion", true, true};
    gi::LightSkinSettings settings;
    settings.glossy = setup.glossy;
    settings.occlusion = setup.occlusion;
    checkSetup(setup, scene, runCpu(scene, settings));
}

INSTANTIATE_TEST_SUITE_P(PaperSetups, CpuLightSkinSetupGLTest,
                         ::testing::Values(PaperSetup{"diffuse", false, false}, PaperSetup{"glossy", true, false},
                                           PaperSetup{"occlusion", true, true},
                                           PaperSetup{"near_field", true, true, true}),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

// ---- numerical extremes (the GL path's suite) --------------------------------------------------
class CpuLightSkinExtremeGLTest : public GlTest, public ::testing::WithParamInterface<GpuExtreme> {};

TEST_P(CpuLightSkinExtremeGLTest, FiniteNonNegativeBoundedAndAgreesWithTheReference) {
    const GpuExtreme& c = GetParam();
    Scene scene = extremeScene(c);
    gi::LightSkinSettings settings;
    settings.occlusion = false;
    settings.nearFieldArea = true; // guard G12 at the extremes too (checkExtreme's reference has it)
    checkExtreme(c, scene, runCpu(scene, settings));
}

INSTANTIATE_TEST_SUITE_P(Extremes, CpuLightSkinExtremeGLTest, ::testing::ValuesIn(gpuExtremes()), extremeName);

// ---- thread count, empty set, settings -------------------------------------------------------
using CpuLightSkinGLTest = GlTest;

template <class T>
bool bitwiseEqual(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

// On every instruction set this CPU supports (core/SimdTarget.h): the test's name carries the target.
class CpuLightSkinThreadCountGLTest : public GlTest, public ::testing::WithParamInterface<std::string> {};

TEST_P(CpuLightSkinThreadCountGLTest, ResultsAreBitwiseIndependentOfTheThreadCount) {
    const core::SimdTargetScope target(GetParam());
    ASSERT_EQ(gi::cpuSimdTarget(), GetParam());
    Scene scene = sphereOverFloor();
    // more than 2048 VALs (a group's pass over all of them) and a count that is no multiple of 16: padding
    const auto extra = randomVals(2601, {-1.5f, -1.5f, 1.0f}, {1.5f, 1.5f, 2.0f}, {0, 0, 0}, 0.002f, 5);
    scene.vals.insert(scene.vals.end(), extra.begin(), extra.end());
    gi::LightSkinSettings settings; // diffuse + glossy + occlusion
    const GpuRun one = runCpu(scene, settings, 1);
    // non-trivial (an all-zero result would pass the equalities): the image carries >= half of the
    // double brute force's light (CarriesTheLight.h; was "max irradiance > 0.1", a chosen number)
    scene.gbuffer.render(scene.instances, scene.view().clip_T_world); // renderAndRead used its own
    expectCarriesTheLight(scene, one.image, scene.vals, true, "1 thread");
    // the first frame and the third (the gather's order planned from the earlier frames' group times);
    // with 7 threads on 2 cores some start late or are preempted, and the others take their groups
    for (const auto& [threads, frames] :
         {std::pair{2, 1}, std::pair{3, 1}, std::pair{7, 1}, std::pair{1, 3}, std::pair{2, 3}, std::pair{3, 3}}) {
        SCOPED_TRACE("frame " + std::to_string(frames));
        const GpuRun other = runCpu(scene, settings, threads, frames);
        EXPECT_TRUE(bitwiseEqual(one.gather, other.gather)) << threads << " threads: gather sums";
        EXPECT_TRUE(bitwiseEqual(one.vpls, other.vpls)) << threads << " threads: renormalised VPLs";
        EXPECT_TRUE(bitwiseEqual(one.occlusion, other.occlusion)) << threads << " threads: occlusion";
        EXPECT_TRUE(bitwiseEqual(one.vertex, other.vertex)) << threads << " threads: vertex VPLs";
        EXPECT_TRUE(bitwiseEqual(one.image, other.image)) << threads << " threads: image";
    }
}

INSTANTIATE_TEST_SUITE_P(EveryInstructionSet, CpuLightSkinThreadCountGLTest, ::testing::ValuesIn(core::simdTargets()),
                         [](const ::testing::TestParamInfo<std::string>& target) { return target.param; });

// The gather skips blocks of 16 VALs x 16 sparse points wholly behind the points (CpuGatherKernels.h,
// prepareGather), and the occlusion skips occluders below the horizon of every point of a vector
// (cpu::occlusion): every term there is exactly +0, so skipping them must change no bit of anything.
// A ceiling emitter in raster order (blocks of 16 neighbouring VALs) over the sphere: the sphere's
// downward-facing points see none of it, so some blocks are skipped, and the floor's points have every
// other floor point in their tangent plane (asserted: else this compares the same computation twice).
TEST_F(CpuLightSkinGLTest, SkippingHiddenBlocksChangesNoBit) {
    Scene scene = sphereOverFloor();
    const auto ceiling = squareEmitter({0.0f, 0.0f, 2.0f}, {0.0f, 0.0f, -1.0f}, 2.0f, 48, {0.8f, 0.7f, 0.6f});
    scene.vals.insert(scene.vals.end(), ceiling.begin(), ceiling.end());
    gi::LightSkinSettings settings; // diffuse + glossy + occlusion
    double occludersOn = 0.0, occludersOff = 0.0;
    const auto run = [&](bool skip, double* skipped) {
        scene.upload();
        gi::CpuLightSkinSettings cpuSettings;
        cpuSettings.lightSkin = settings;
        cpuSettings.threads = 2;
        cpuSettings.skipHiddenBlocks = skip;
        auto technique = gi::CpuLightSkin::create(cpuSettings, scene.provider());
        technique->prepare(scene.instances);
        GpuRun result = renderAndRead(scene, *technique);
        *skipped = technique->lastStats().gatherBlocksSkipped;
        (skip ? occludersOn : occludersOff) = technique->lastStats().occlusionPairsSkipped;
        return result;
    };
    // every instruction set: the vector width decides which points share a skip decision
    GpuRun skipping;
    for (const std::string& target : gi::cpuSimdTargets()) {
        SCOPED_TRACE("instruction set " + target);
        gi::setCpuSimdTarget(target);
        double skippedOn = 0.0, skippedOff = 0.0;
        const GpuRun all = run(false, &skippedOff);
        skipping = run(true, &skippedOn);
        EXPECT_EQ(skippedOff, 0.0);
        EXPECT_GT(skippedOn, 0.0) << "no block was skipped: the test would compare a computation with itself";
        EXPECT_EQ(occludersOff, 0.0);
        EXPECT_GT(occludersOn, 0.0) << "no occluder was skipped: the occlusion would compare a computation with itself";
        std::printf("%s: blocks skipped: %.1f %%, occluder pairs skipped: %.1f %%\n", target.c_str(), 100.0 * skippedOn,
                    100.0 * occludersOn);
        EXPECT_TRUE(bitwiseEqual(all.gather, skipping.gather)) << "gather sums";
        EXPECT_TRUE(bitwiseEqual(all.vpls, skipping.vpls)) << "renormalised VPLs";
        EXPECT_TRUE(bitwiseEqual(all.occlusion, skipping.occlusion)) << "occlusion";
        EXPECT_TRUE(bitwiseEqual(all.vertex, skipping.vertex)) << "vertex VPLs";
        EXPECT_TRUE(bitwiseEqual(all.image, skipping.image)) << "image";
    }
    gi::setCpuSimdTarget("");
    // and not all zero: the image carries the light (CarriesTheLight.h)
    scene.gbuffer.render(scene.instances, scene.view().clip_T_world);
    expectCarriesTheLight(scene, skipping.image, scene.vals, true, "skipping");
}

TEST_F(CpuLightSkinGLTest, EmptyValSetGivesExactlyZeroAndStageTimesAreReported) {
    Scene scene = sphereOverFloor();
    scene.vals.clear();
    const GpuRun run = runCpu(scene, {});
    for (const glm::vec4& p : run.image) EXPECT_EQ(p, glm::vec4(0.0f));
    std::vector<std::string> names;
    for (const gl::StageTime& t : run.times) {
        names.push_back(t.name);
        EXPECT_GE(t.milliseconds, 0.0);
    }
    EXPECT_EQ(names,
              (std::vector<std::string>{"upload", "gather", "normalisation", "occlusion", "interpolation", "shading"}));
}

TEST_F(CpuLightSkinGLTest, RejectsANegativeThreadCount) {
    Scene scene = sphereOverFloor();
    gi::CpuLightSkinSettings settings;
    settings.threads = -1;
    EXPECT_THROW(gi::CpuLightSkin::create(settings, scene.provider()), Error);
}

// The kernels dispatch to the best instruction set allowed, and honour LIGHTSKIN_SIMD_TARGET (the capped
// runs of this program, tests/gi/gather/CMakeLists.txt).
TEST_F(CpuLightSkinGLTest, ReportsTheDispatchedInstructionSet) {
    const std::vector<std::string> targets = core::simdTargets();
    ASSERT_FALSE(targets.empty());
    EXPECT_EQ(gi::cpuSimdTarget(), targets.front());
    const char* cap = std::getenv(core::kSimdTargetVariable);
    if (cap != nullptr && std::find(targets.begin(), targets.end(), cap) != targets.end()) {
        EXPECT_EQ(gi::cpuSimdTarget(), cap);
    }
    std::printf("dispatched instruction set: %s\n", gi::cpuSimdTarget().c_str());
}

} // namespace
} // namespace lightskin::test
