// Adaptive mode, static content (LightSkinSettings::reuseStatic / staticTolerance): identical
// inputs skip stages 0-4 and give the image of the full computation bit for bit; a changed VAL
// set, a moved instance or (with the glossy channel) a moved camera recompute and agree with a
// fresh technique; a moved camera without the glossy channel may reuse (the diffuse gather is
// view-independent); the tolerance mode keeps every sparse point's gathered irradiance within its
// stated bound of a full recomputation; the empty VAL set; the ValGenerator's generation
// (skipUnchangedInput). What reuse saves in time is a benchmark, not a test (timings flake on a
// shared machine): `lightskin bench-static`, docs/BENCHMARKS.md "Adaptive mode: static content".
//
// "Equal to a fresh technique" is bit for bit: the adaptive cull keeps the VALs' input order
// (gather_cull.glsl), so two full computations sum in the same order. Reuse itself is checked bit
// for bit against the full computation it reuses. Every comparison of two runs also requires the
// image to carry the light (expectCarriesTheLight: >= half of the double brute force), since two
// all-zero images are equal bit for bit too.
#include "CarriesTheLight.h"
#include "common/GatherTestScenes.h"
#include "GlTestEnvironment.h"
#include "common/GpuRig.h"

#include <lightskin/core/Pose.h>
#include <lightskin/gi/lightskin/LightSkinIllumination.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gi/common/ValGenerator.h>
#include <lightskin/gi/common/VertexSparsePoints.h>
#include <lightskin/gl/Objects.h>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <random>

namespace lightskin::test {
namespace {

/// Frames are rendered with explicit inputs (see render() below).
using Rig = GpuRig;

struct Frame {
    std::vector<glm::vec4> image, gather, vertex;
    std::vector<gl::StageTime> times;
    gi::LightSkinChoice choice;
};

Frame render(Rig& rig, gi::LightSkinIllumination& technique, const gi::ValSetView& vals) {
    const gi::ViewParameters view = rig.view();
    rig.gbuffer.render(rig.instances, view.clip_T_world);
    technique.render(vals, rig.instances, rig.gbuffer.view(), view, rig.output.id());
    Frame f;
    f.image.resize(std::size_t(rig.width) * std::size_t(rig.height));
    glGetTextureImage(rig.output.id(), 0, GL_RGBA, GL_FLOAT, GLsizei(f.image.size() * sizeof(glm::vec4)),
                      f.image.data());
    technique.readGatherSums(f.gather);
    technique.readVertexVpls(f.vertex);
    technique.lastStageTimes(f.times);
    f.choice = technique.lastChoice();
    return f;
}

/// max |a - b| / max |b| over rgb (0 if b is all zero and a == b).
double relativeDifference(const std::vector<glm::vec4>& a, const std::vector<glm::vec4>& b) {
    EXPECT_EQ(a.size(), b.size());
    double largest = 0.0, worst = 0.0;
    for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
        for (int c = 0; c < 3; ++c) {
            largest = std::max(largest, double(std::abs(b[i][c])));
            worst = std::max(worst, double(std::abs(a[i][c] - b[i][c])));
        }
    return largest > 0.0 ? worst / largest : worst;
}

/// A fresh technique computes its first frame in full and reuses on the second: the tolerance
/// decision does not depend on the technique's history.
template <class RunPair>
void expectFreshPairReuses(RunPair runPair) {
    const auto [full, reused] = runPair();
    EXPECT_FALSE(full.choice.reused);
    EXPECT_TRUE(reused.choice.reused) << reused.choice.reason;
}

bool bitIdentical(const std::vector<glm::vec4>& a, const std::vector<glm::vec4>& b) {
    return a.size() == b.size() &&
           std::equal(a.begin(), a.end(), b.begin(),
                      [](const glm::vec4& x, const glm::vec4& y) { return std::memcmp(&x, &y, sizeof x) == 0; });
}

/// The gather test scene: a glossy sphere over a glossy floor (two objects, so the adaptive mode
/// keeps glossy and occlusion), a wall emitter and random VALs (some culled).
Rig sphereOverFloor(bool glossy) {
    Rig rig;
    Material sphere;
    sphere.diffuseAlbedo = {0.8f, 0.7f, 0.6f};
    sphere.specularAlbedo = glm::vec3(glossy ? 0.3f : 0.0f);
    sphere.specularExponent = 20.0f;
    rig.add(makeSphere(0.3f, 12, 24), glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 0.45f}), sphere, 120);
    Material floor;
    floor.diffuseAlbedo = {0.5f, 0.5f, 0.5f};
    floor.specularAlbedo = glm::vec3(glossy ? 0.2f : 0.0f);
    floor.specularExponent = 5.0f;
    rig.add(makeGrid(2.0f, 12), glm::mat4(1.0f), floor, 60);
    rig.upload();
    return rig;
}

std::vector<gi::VirtualAreaLight> sceneVals() {
    auto vals = squareEmitter({-1.0f, 0.0f, 0.6f}, {1.0f, 0.0f, 0.0f}, 1.2f, 24, {1.0f, 0.8f, 0.6f});
    const auto extra = randomVals(424, {-1.5f, -1.5f, 1.0f}, {1.5f, 1.5f, 2.0f}, {0, 0, 0}, 0.005f, 11);
    vals.insert(vals.end(), extra.begin(), extra.end());
    return vals;
}

gl::Buffer upload(const std::vector<gi::VirtualAreaLight>& vals) {
    return gl::Buffer::create(GLsizeiptr(std::max<std::size_t>(vals.size(), 1) * sizeof(gi::VirtualAreaLight)),
                              vals.empty() ? nullptr : vals.data(), GL_DYNAMIC_STORAGE_BIT);
}

gi::LightSkinSettings adaptive() {
    gi::LightSkinSettings s;
    s.adaptive = true;
    return s;
}

using LightSkinStaticGLTest = GlTest;

TEST_F(LightSkinStaticGLTest, IdenticalInputsSkipTheStagesAndGiveTheSameImageBitForBit) {
    Rig rig = sphereOverFloor(true);
    const auto vals = sceneVals();
    const gl::Buffer buffer = upload(vals);
    const gi::ValSetView set{buffer.id(), std::uint32_t(vals.size()), 7};
    auto technique = rig.technique(adaptive());
    const Frame full = render(rig, *technique, set);
    EXPECT_FALSE(full.choice.reused);
    ASSERT_TRUE(full.choice.glossy && full.choice.occlusion);
    expectCarriesTheLight(rig, full.image, vals, true, "full computation");
    const Frame reused = render(rig, *technique, set);
    EXPECT_TRUE(reused.choice.reused) << reused.choice.reason;
    EXPECT_NE(reused.choice.reason.find("reused"), std::string::npos);
    EXPECT_EQ(reused.choice.valsGathered, full.choice.valsGathered);
    EXPECT_TRUE(bitIdentical(reused.image, full.image));
    EXPECT_TRUE(bitIdentical(reused.vertex, full.vertex));
    // the same stages are reported (their times: `lightskin bench-static`)
    ASSERT_EQ(reused.times.size(), full.times.size());
    for (std::size_t i = 0; i < full.times.size(); ++i) EXPECT_EQ(reused.times[i].name, full.times[i].name);

    // a full recomputation by a fresh technique
    auto fresh = rig.technique(adaptive());
    const Frame reference = render(rig, *fresh, set);
    EXPECT_TRUE(bitIdentical(reused.image, reference.image));

    // generation 0 (unknown) never counts as unchanged; nor does reuse switched off
    const Frame unknown = render(rig, *technique, {buffer.id(), std::uint32_t(vals.size()), 0});
    EXPECT_FALSE(unknown.choice.reused);
    gi::LightSkinSettings off = adaptive();
    off.reuseStatic = false;
    technique->setSettings(off);
    for (int i = 0; i < 2; ++i) EXPECT_FALSE(render(rig, *technique, set).choice.reused);
}

TEST_F(LightSkinStaticGLTest, ChangedValsMovedInstanceOrMovedGlossyCameraRecompute) {
    Rig rig = sphereOverFloor(true);
    auto vals = sceneVals();
    gl::Buffer buffer = upload(vals);
    auto technique = rig.technique(adaptive());
    (void)render(rig, *technique, {buffer.id(), std::uint32_t(vals.size()), 1});
    ASSERT_TRUE(render(rig, *technique, {buffer.id(), std::uint32_t(vals.size()), 1}).choice.reused);

    const auto expectFreshResult = [&](const gi::ValSetView& set, const char* what) {
        const Frame frame = render(rig, *technique, set);
        EXPECT_FALSE(frame.choice.reused) << what;
        auto fresh = rig.technique(adaptive());
        const Frame reference = render(rig, *fresh, set);
        EXPECT_TRUE(bitIdentical(frame.image, reference.image)) << what;
        EXPECT_TRUE(bitIdentical(frame.vertex, reference.vertex)) << what;
        expectCarriesTheLight(rig, frame.image, vals, true, what);
        EXPECT_TRUE(render(rig, *technique, set).choice.reused) << what << ": the next identical frame reuses";
    };

    // changed VALs: the producer bumps the generation
    for (auto& v : vals) v.flux *= 1.5f;
    glNamedBufferSubData(buffer.id(), 0, GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)), vals.data());
    expectFreshResult({buffer.id(), std::uint32_t(vals.size()), 2}, "changed VALs");
    const gi::ValSetView set{buffer.id(), std::uint32_t(vals.size()), 2};

    // a moved instance
    rig.instances[0].world_T_model = glm::translate(glm::mat4(1.0f), {0.05f, 0.0f, 0.45f});
    expectFreshResult(set, "moved instance");
    // a changed Phong exponent (the sparse points carry k)
    rig.instances[1].material.specularExponent = 9.0f;
    expectFreshResult(set, "changed exponent");
    // a moved camera with the glossy channel on: eq. 5 depends on the eye
    rig.eye = {1.2f, -2.0f, 1.6f};
    expectFreshResult(set, "moved camera, glossy");
}

TEST_F(LightSkinStaticGLTest, MovedCameraWithoutGlossyReusesTheViewIndependentVpls) {
    Rig rig = sphereOverFloor(false); // no f_s: the adaptive mode turns the glossy channel off
    const auto vals = sceneVals();
    const gl::Buffer buffer = upload(vals);
    const gi::ValSetView set{buffer.id(), std::uint32_t(vals.size()), 1};
    auto technique = rig.technique(adaptive());
    (void)render(rig, *technique, set);
    rig.eye = {1.0f, -2.2f, 1.2f};
    const Frame moved = render(rig, *technique, set);
    EXPECT_FALSE(moved.choice.glossy);
    EXPECT_TRUE(moved.choice.reused);
    auto fresh = rig.technique(adaptive());
    const Frame reference = render(rig, *fresh, set);
    EXPECT_TRUE(bitIdentical(moved.vertex, reference.vertex));
    EXPECT_TRUE(bitIdentical(moved.image, reference.image));
    expectCarriesTheLight(rig, moved.image, vals, false, "moved camera, diffuse");
}

TEST_F(LightSkinStaticGLTest, EmptyValSetIsZeroAndReusedUntilLightArrives) {
    Rig rig = sphereOverFloor(true);
    const auto vals = sceneVals();
    const gl::Buffer buffer = upload(vals);
    auto technique = rig.technique(adaptive());
    const gi::ValSetView empty{buffer.id(), 0, 0}; // an empty set is identical to an empty set
    const Frame first = render(rig, *technique, empty);
    const Frame second = render(rig, *technique, empty);
    EXPECT_FALSE(first.choice.reused);
    EXPECT_TRUE(second.choice.reused);
    for (const Frame* f : {&first, &second})
        for (const glm::vec4& p : f->image) ASSERT_EQ(p, glm::vec4(0.0f));
    const Frame lit = render(rig, *technique, {buffer.id(), std::uint32_t(vals.size()), 3});
    EXPECT_FALSE(lit.choice.reused);
    expectCarriesTheLight(rig, lit.image, vals, true, "light after an empty set");
    const Frame dark = render(rig, *technique, empty);
    EXPECT_FALSE(dark.choice.reused);
    for (const glm::vec4& p : dark.image) ASSERT_EQ(p, glm::vec4(0.0f));
}

// ---- tolerance mode ---------------------------------------------------------------------------
/// One diffuse sphere lit by a keyed square emitter 0.9 m away; `jitter` moves each VAL by up to
/// `positionNoise` metres and scales its flux by up to 1 +- fluxNoise (a noisy static sensor).
std::vector<gi::VirtualAreaLight> jittered(const std::vector<gi::VirtualAreaLight>& base, float positionNoise,
                                           float fluxNoise, std::uint32_t seed) {
    std::mt19937 random(seed);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    auto out = base;
    for (auto& v : out) {
        v.position += positionNoise * glm::vec3(unit(random), unit(random), unit(random)) / std::sqrt(3.0f);
        v.flux *= 1.0f + fluxNoise * unit(random);
    }
    return out;
}

/// The tolerance-mode scene: one diffuse sphere (1500 sparse points) lit by a wall emitter beside it.
Rig diffuseSphereRig() {
    Rig rig;
    Material diffuse;
    rig.add(makeSphere(0.3f, 24, 48), glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 0.3f}), diffuse, 1500);
    rig.eye = {1.5f, -1.5f, 1.0f};
    rig.upload();
    return rig;
}

/// The wall emitter of diffuseSphereRig(): 48 x 48 discs on a 1.6 m square.
std::vector<gi::VirtualAreaLight> wallEmitter() {
    return squareEmitter({0.0f, -1.2f, 0.6f}, {0.0f, 1.0f, -0.2f}, 1.6f, 48, {1.0f, 0.9f, 0.8f});
}

TEST_F(LightSkinStaticGLTest, ToleranceModeStaysWithinItsBound) {
    Rig rig = diffuseSphereRig();
    const auto base = wallEmitter();
    std::vector<std::uint32_t> keys(base.size());
    for (std::uint32_t i = 0; i < keys.size(); ++i) keys[i] = std::uint32_t(keys.size()) - 1 - i; // any stable naming
    const gl::Buffer keyBuffer = gl::Buffer::create(GLsizeiptr(keys.size() * sizeof(std::uint32_t)), keys.data(), 0);
    const auto keyed = [&](const gl::Buffer& b, std::uint64_t generation) {
        return gi::ValSetView{b.id(), std::uint32_t(base.size()), generation, keyBuffer.id(),
                              std::uint32_t(base.size())};
    };
    const float tolerance = 0.1f;
    gi::LightSkinSettings settings = adaptive();
    settings.staticTolerance = tolerance;
    auto technique = rig.technique(settings);
    const gl::Buffer first = upload(jittered(base, 1e-3f, 0.01f, 1));
    const Frame full = render(rig, *technique, keyed(first, 1));
    EXPECT_FALSE(full.choice.reused);
    EXPECT_FALSE(full.choice.glossy);

    // a new noisy frame of the same static scene: 1 mm and 1 % noise
    const gl::Buffer second = upload(jittered(base, 1e-3f, 0.01f, 2));
    const Frame reused = render(rig, *technique, keyed(second, 2));
    ASSERT_TRUE(reused.choice.reused) << "bound " << reused.choice.staticChangeBound;
    EXPECT_GT(reused.choice.staticChangeBound, 0.0f);
    EXPECT_LE(reused.choice.staticChangeBound, tolerance);
    expectFreshPairReuses([&] {
        auto fresh = rig.technique(settings);
        Frame a = render(rig, *fresh, keyed(first, 1));
        Frame b = render(rig, *fresh, keyed(second, 2));
        return std::pair{std::move(a), std::move(b)};
    });

    // against a full recomputation of the second frame: every sparse point's L'_d (slot 0 of 5)
    // within the stated bound, staticChangeBound * max L'_d (+ 1e-5 float rounding of the gather)
    gi::LightSkinSettings exact = adaptive();
    auto fresh = rig.technique(exact);
    const Frame reference = render(rig, *fresh, keyed(second, 2));
    double largest = 0.0, worst = 0.0;
    for (std::size_t i = 0; i < reference.gather.size(); i += 5)
        for (int c = 0; c < 3; ++c) {
            largest = std::max(largest, double(full.gather[i][c]));
            worst = std::max(worst, double(std::abs(reused.gather[i][c] - reference.gather[i][c])));
        }
    ASSERT_GT(largest, 0.0);
    expectCarriesTheLight(rig, reused.image, jittered(base, 1e-3f, 0.01f, 2), false, "reused within the tolerance");
    EXPECT_LE(worst / largest, double(reused.choice.staticChangeBound) + 1e-5);
    EXPECT_GT(worst / largest, 0.0) << "the noise must change the gather";
    std::printf("tolerance mode: bound %.4f, measured L'_d change %.5f, image change %.5f (relative to the maximum)\n",
                double(reused.choice.staticChangeBound), worst / largest,
                relativeDifference(reused.image, reference.image));

    // larger noise (2 cm) exceeds the tolerance: recomputed, and equal to a fresh computation
    const gl::Buffer noisy = upload(jittered(base, 2e-2f, 0.2f, 3));
    const Frame recomputed = render(rig, *technique, keyed(noisy, 3));
    EXPECT_FALSE(recomputed.choice.reused);
    EXPECT_GT(recomputed.choice.staticChangeBound, tolerance);
    auto fresh2 = rig.technique(exact);
    EXPECT_TRUE(bitIdentical(recomputed.image, render(rig, *fresh2, keyed(noisy, 3)).image));

    // without keys the tolerance mode cannot compare: only exact reuse
    const Frame unkeyed = render(rig, *technique, {second.id(), std::uint32_t(base.size()), 4});
    EXPECT_FALSE(unkeyed.choice.reused);
}

TEST_F(LightSkinStaticGLTest, ProbeModeHoldsTheToleranceAtTheProbesWithoutKeys) {
    Rig rig = diffuseSphereRig();
    const auto base = wallEmitter();
    const auto set = [&](const gl::Buffer& b, std::uint64_t generation) {
        return gi::ValSetView{b.id(), std::uint32_t(base.size()), generation}; // no keys
    };
    const float tolerance = 0.01f;
    const int stride = 8;
    gi::LightSkinSettings settings = adaptive();
    settings.staticTolerance = tolerance;
    settings.staticChangeTest = gi::StaticChangeTest::Probes;
    settings.staticProbeStride = stride;
    auto technique = rig.technique(settings);
    const gl::Buffer first = upload(jittered(base, 1e-3f, 0.01f, 1));
    const Frame full = render(rig, *technique, set(first, 1));
    EXPECT_FALSE(full.choice.reused);
    const gl::Buffer second = upload(jittered(base, 1e-3f, 0.01f, 2));
    const Frame reused = render(rig, *technique, set(second, 2));
    ASSERT_TRUE(reused.choice.reused) << "probe change " << reused.choice.staticChangeBound;
    EXPECT_LE(reused.choice.staticChangeBound, tolerance);
    expectFreshPairReuses([&] {
        auto fresh = rig.technique(settings);
        Frame a = render(rig, *fresh, set(first, 1));
        Frame b = render(rig, *fresh, set(second, 2));
        return std::pair{std::move(a), std::move(b)};
    });

    // the probe measure is the true change at the probes (a fresh computation there), and the
    // tolerance holds there; elsewhere it is measured
    auto fresh = rig.technique(adaptive());
    const Frame reference = render(rig, *fresh, set(second, 2));
    double largest = 0.0, atProbes = 0.0, everywhere = 0.0;
    for (std::size_t point = 0; point * 5 < reference.gather.size(); ++point)
        for (int c = 0; c < 3; ++c) {
            const double diff = std::abs(double(reused.gather[5 * point][c]) - double(reference.gather[5 * point][c]));
            largest = std::max(largest, double(full.gather[5 * point][c]));
            everywhere = std::max(everywhere, diff);
            if (point % std::size_t(stride) == 0) atProbes = std::max(atProbes, diff);
        }
    ASSERT_GT(largest, 0.0);
    expectCarriesTheLight(rig, reused.image, jittered(base, 1e-3f, 0.01f, 2), false, "reused at the probes");
    EXPECT_GT(atProbes, 0.0);
    // 1e-5: float summation order of two gathers of ~2300 positive terms
    EXPECT_NEAR(atProbes / largest, double(reused.choice.staticChangeBound), 1e-5);
    EXPECT_LE(atProbes / largest, double(tolerance) + 1e-5);
    std::printf(
        "probe mode: change at the probes %.5f, at all sparse points %.5f, image %.5f (relative to the maximum)\n",
        atProbes / largest, everywhere / largest, relativeDifference(reused.image, reference.image));

    // independent noise cancels (2 cm / 20 % noise moves L'_d by ~0.3 %); a light turned up by
    // 5 % does not: recomputed, equal to a fresh computation
    auto brighter = jittered(base, 1e-3f, 0.01f, 2);
    for (auto& v : brighter) v.flux *= 1.05f;
    const gl::Buffer noisy = upload(brighter);
    const Frame recomputed = render(rig, *technique, set(noisy, 3));
    EXPECT_FALSE(recomputed.choice.reused);
    EXPECT_GT(recomputed.choice.staticChangeBound, tolerance);
    auto fresh2 = rig.technique(adaptive());
    EXPECT_TRUE(bitIdentical(recomputed.image, render(rig, *fresh2, set(noisy, 3)).image));
    // the glossy channel needs exact reuse
    rig.instances[0].material.specularAlbedo = glm::vec3(0.2f);
    (void)render(rig, *technique, set(noisy, 3));
    EXPECT_FALSE(render(rig, *technique, set(second, 4)).choice.reused);
}

TEST_F(LightSkinStaticGLTest, ChangeBoundHoldsForRandomSingleValChanges) {
    // The derivation in gather_static_bound.comp, checked against full recomputations: one of a
    // few VALs near a diffuse sphere moves (<= 5 cm), tilts (<= 0.3), changes area (+-30 %) and
    // flux (+-30 %); the largest change of any sparse point's L'_d must not exceed the bound.
    Rig rig;
    Material diffuse;
    rig.add(makeSphere(0.3f, 12, 24), glm::mat4(1.0f), diffuse, 200);
    rig.upload();
    std::vector<gi::VirtualAreaLight> base =
        randomVals(12, {-0.9f, -0.9f, -0.9f}, {0.9f, 0.9f, 0.9f}, {0, 0, 0}, 0.01f, 5);
    for (auto& v : base) // keep the VALs outside the sphere
        if (glm::length(v.position) < 0.5f) v.position *= 0.5f / glm::length(v.position);
    std::vector<std::uint32_t> keys(base.size());
    for (std::uint32_t i = 0; i < keys.size(); ++i) keys[i] = i;
    const gl::Buffer keyBuffer = gl::Buffer::create(GLsizeiptr(keys.size() * sizeof(std::uint32_t)), keys.data(), 0);
    const auto keyed = [&](const gl::Buffer& b, std::uint64_t generation) {
        return gi::ValSetView{b.id(), std::uint32_t(base.size()), generation, keyBuffer.id(),
                              std::uint32_t(base.size())};
    };
    const gl::Buffer baseBuffer = upload(base);
    auto baseTechnique = rig.technique(adaptive());
    const Frame reference = render(rig, *baseTechnique, keyed(baseBuffer, 1));
    double largest = 0.0;
    for (std::size_t i = 0; i < reference.gather.size(); i += 5)
        for (int c = 0; c < 3; ++c) largest = std::max(largest, double(reference.gather[i][c]));
    ASSERT_GT(largest, 0.0);

    std::mt19937 random(17);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    double tightest = 1e30;
    for (int trial = 0; trial < 12; ++trial) {
        auto changed = base;
        gi::VirtualAreaLight& v = changed[std::size_t(trial) % changed.size()];
        v.position += 0.05f * glm::vec3(unit(random), unit(random), unit(random)) / std::sqrt(3.0f);
        v.normal =
            glm::normalize(v.normal + 0.3f * glm::vec3(unit(random), unit(random), unit(random)) / std::sqrt(3.0f));
        v.area *= 1.0f + 0.3f * unit(random);
        v.flux *= 1.0f + 0.3f * unit(random);
        const gl::Buffer buffer = upload(changed);
        gi::LightSkinSettings settings = adaptive();
        settings.staticTolerance = 1e30f; // always reuse: only the reported bound matters here
        auto technique = rig.technique(settings);
        (void)render(rig, *technique, keyed(baseBuffer, 1));
        const Frame check = render(rig, *technique, keyed(buffer, 2));
        ASSERT_TRUE(check.choice.reused);
        auto fresh = rig.technique(adaptive());
        const Frame truth = render(rig, *fresh, keyed(buffer, 2));
        double worst = 0.0;
        for (std::size_t i = 0; i < truth.gather.size(); i += 5)
            for (int c = 0; c < 3; ++c)
                worst = std::max(worst, double(std::abs(truth.gather[i][c] - reference.gather[i][c])));
        const double bound = double(check.choice.staticChangeBound);
        EXPECT_LE(worst / largest, bound * (1.0 + 1e-3) + 1e-5) << "trial " << trial;
        if (worst > 1e-3 * largest) tightest = std::min(tightest, bound / (worst / largest));
    }
    std::printf("single-VAL changes: the bound exceeds the true change by a factor >= %.2f\n", tightest);
}

// ---- the producer side ---------------------------------------------------------------------
TEST_F(LightSkinStaticGLTest, ValGeneratorKeepsTheGenerationForIdenticalInput) {
    const int w = 64, h = 48;
    cv::Mat depth(h, w, CV_32FC1, cv::Scalar(1.5f));
    cv::Mat colour(h, w, CV_8UC3, cv::Scalar(90, 120, 200));
    CameraIntrinsics K;
    K.width = w;
    K.height = h;
    K.fx = K.fy = 60.0;
    K.cx = 31.5;
    K.cy = 23.5;
    gi::ValGeneratorSettings settings;
    settings.stride = 2;
    settings.normalWindowRadius = 2;
    settings.skipUnchangedInput = true;
    gi::ValGenerator generator = gi::ValGenerator::create(w, h, settings);
    const gi::ValSetView a = generator.generate(depth, 1.0, colour, K, Pose());
    ASSERT_GT(a.count, 0u);
    EXPECT_NE(a.generation, 0u);
    EXPECT_EQ(a.keys, generator.pixelIndexBuffer());
    EXPECT_EQ(a.keyCount, std::uint32_t(w * h));
    const gi::ValSetView b = generator.generate(depth, 1.0, colour, K, Pose());
    EXPECT_TRUE(generator.lastSkipped());
    EXPECT_EQ(b.generation, a.generation);
    EXPECT_EQ(b.count, a.count);

    depth.at<float>(20, 30) = 1.51f;
    const gi::ValSetView c = generator.generate(depth, 1.0, colour, K, Pose());
    EXPECT_FALSE(generator.lastSkipped());
    EXPECT_GT(c.generation, b.generation);
    colour.at<cv::Vec3b>(5, 5) = cv::Vec3b(0, 0, 0);
    EXPECT_GT(generator.generate(depth, 1.0, colour, K, Pose()).generation, c.generation);
    const gi::ValSetView d = generator.lastSet();
    EXPECT_GT(generator.generate(depth, 1.0, colour, K, Pose(glm::dquat(1, 0, 0, 0), {0.0, 0.0, 0.01})).generation,
              d.generation);
    settings.exposure = 2.0f;
    generator.setSettings(settings);
    const std::uint64_t before = generator.lastSet().generation;
    EXPECT_GT(generator.generate(depth, 1.0, colour, K, Pose(glm::dquat(1, 0, 0, 0), {0.0, 0.0, 0.01})).generation,
              before);

    // off (the default): every call runs the pass
    settings.skipUnchangedInput = false;
    generator.setSettings(settings);
    const std::uint64_t g1 = generator.generate(depth, 1.0, colour, K, Pose()).generation;
    EXPECT_GT(generator.generate(depth, 1.0, colour, K, Pose()).generation, g1);
    EXPECT_FALSE(generator.lastSkipped());
}

} // namespace
} // namespace lightskin::test
