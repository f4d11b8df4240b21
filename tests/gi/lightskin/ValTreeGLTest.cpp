// The GL path's gather with a cut through the VAL tree (LightSkinSettings::valTreeThreshold,
// gi/lightskin/shaders/gather_tree.comp) against the double reference of the same walk (ValTreeReference.h) and the
// flat double gather, with the walk split into many short dispatches (llvmpipe's loop limit) so that the
// saved stack and estimate are resumed.
#include "common/GatherTestScenes.h"
#include "GlTestEnvironment.h"
#include "common/GpuRig.h"
#include "ValTreeScenes.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/lightskin/CpuLightSkin.h>
#include <lightskin/gi/lightskin/GpuValQuadtree.h>
#include <lightskin/gi/lightskin/LightSkinIllumination.h>
#include <lightskin/gi/reference/LightSkinReference.h>
#include <lightskin/gi/lightskin/ValTree.h>
#include <lightskin/gi/reference/ValTreeReference.h>
#include <lightskin/gl/Objects.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace lightskin::test {
namespace {

namespace ref = gi::reference;
using ValTreeGLTest = GlTest;

struct GatherRun {
    std::vector<glm::vec4> sums;
    gi::LightSkinChoice choice;
};

// A room of 3 x 48^2 = 6912 VALs around a glossy sphere with 200 sparse points.
struct RoomScene : GpuRig {
    std::vector<gi::VirtualAreaLight> vals;
    gl::Buffer buffer;
    RoomScene() {
        width = height = 32;
        Material material;
        material.specularAlbedo = glm::vec3(0.3f);
        material.specularExponent = 20.0f;
        add(makeSphere(0.3f, 16, 24), glm::mat4(1.0f), material, 200);
        upload();
        const auto addVals = [&](const std::vector<gi::VirtualAreaLight>& v) {
            vals.insert(vals.end(), v.begin(), v.end());
        };
        addVals(squareEmitter({0, 0, -0.5f}, {0, 0, 1}, 3.0f, 48, glm::vec3(0.8f)));
        addVals(squareEmitter({-1.0f, 0, 0.5f}, {1, 0, 0}, 3.0f, 48, glm::vec3(0.9f, 0.1f, 0.1f)));
        addVals(squareEmitter({0, 1.5f, 0.5f}, {0, -1, 0}, 3.0f, 48, glm::vec3(0.05f, 0.3f, 0.05f)));
        buffer = gl::Buffer::create(GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)), vals.data());
        // pixel keys: the three 48 x 48 squares stacked into a 48 x 144 image (row-major, as ValGenerator's)
        for (std::size_t i = 0; i < vals.size(); ++i) keys.push_back(std::uint32_t(i));
        keyBuffer = gl::Buffer::create(GLsizeiptr(keys.size() * sizeof(std::uint32_t)), keys.data());
    }
    static constexpr std::uint32_t kKeyWidth = 48;
    std::vector<std::uint32_t> keys;
    gl::Buffer keyBuffer;
    // quadtree: the set carries its pixel keys, so the GL path builds the image quadtree instead of the BVH
    GatherRun run(float threshold, int steps, bool quadtree = false, std::uint32_t minVals = 0) {
        gi::LightSkinSettings s;
        s.valTreeThreshold = threshold;
        s.valTreeMinVals = minVals;
        s.valTreeStepsPerDispatch = steps;
        auto technique = this->technique(s);
        const gi::ViewParameters v = view();
        gbuffer.render(instances, v.clip_T_world);
        const auto count = std::uint32_t(vals.size());
        const gi::ValSetView set = quadtree ? gi::ValSetView{buffer.id(), count, 0, keyBuffer.id(), count, kKeyWidth}
                                            : gi::ValSetView{buffer.id(), count};
        technique->render(set, instances, gbuffer.view(), v, output.id());
        GatherRun r;
        technique->readGatherSums(r.sums);
        r.choice = technique->lastChoice();
        receivers = ref::receiversFromSparsePoints(technique->sparsePoints()[0], instances[0].world_T_model, 20.0);
        return r;
    }
    std::vector<ref::Receiver> receivers;
};

void cutMatchesTheDoubleWalk(bool quadtree) {
    RoomScene scene;
    const float threshold = 0.05f;
    // 64 steps per dispatch: every point needs several dispatches (checked below), so resuming is tested
    const GatherRun tree = scene.run(threshold, 64, quadtree);
    EXPECT_EQ(tree.choice.valTreeQuadtree, quadtree);
    const GatherRun flat = scene.run(0.0f, 64);
    ASSERT_EQ(tree.sums.size(), 5 * scene.receivers.size());
    EXPECT_GT(tree.choice.valTreeVisitedPerPoint, 3.0f * 64.0f);
    EXPECT_EQ(tree.choice.valTreeNodes, 2 * scene.vals.size() - 1);
    EXPECT_LT(tree.choice.valTreeCutPerPoint, 0.25f * float(scene.vals.size())) << "the cut must cut";
    EXPECT_EQ(flat.choice.valTreeNodes, 0u);

    // the reference walks the tree the GL path walked: the GPU quadtree (its build is deterministic:
    // each node is computed by one invocation from its children; ValTreeGpuBuildGLTest compares it
    // with the CPU builder's) or the BVH
    gi::ValTreeD treeD;
    if (quadtree) {
        gi::GpuValQuadtree builder = gi::GpuValQuadtree::create();
        const auto count = std::uint32_t(scene.vals.size());
        builder.build(gi::ValSetView{scene.buffer.id(), count, 0, scene.keyBuffer.id(), count, RoomScene::kKeyWidth});
        std::vector<gi::ValCluster> nodes;
        builder.readNodes(nodes);
        treeD = widenValTree(nodes);
    } else {
        gi::buildValTreeInto(scene.vals, treeD);
    }
    const glm::dvec3 eye(scene.eye);
    ref::GatherParameters parameters;
    parameters.epsilonL = 0.0; // the GPU adds the eps_l terms in the renormalisation
    std::vector<ref::GatherSums> cutRef, flatRef;
    std::vector<ref::CutBound> bounds;
    ref::CutStatistics stats;
    ref::gatherWithCutInto(treeD, scene.vals, scene.receivers, eye, parameters, threshold, cutRef, &bounds, &stats);
    ref::gatherInto(scene.vals, scene.receivers, eye, parameters, flatRef);
    // The float walk takes the double walk's cut except where a decision lies within float rounding of
    // the threshold; either cut is within its certified bound of the flat sum, so
    //   |L_gl - L_ref| <= |L_gl - L_flat| + |L_ref - L_flat| <= B_gl + B_ref ~ 2 B_ref,
    // plus float rounding of the sums: 1e-4 relative (~1000 terms x 6e-8, with margin).
    double lit = 0.0, errorTree = 0.0, errorFlat = 0.0, norm = 0.0;
    for (std::size_t i = 0; i < scene.receivers.size(); ++i) {
        const glm::dvec3 gl(tree.sums[5 * i]), glFlat(flat.sums[5 * i]);
        const glm::dvec3 glS(tree.sums[5 * i + 2]);
        for (int c = 0; c < 3; ++c) {
            EXPECT_LE(std::abs(gl[c] - cutRef[i].irradiance[c]),
                      2.0 * bounds[i].irradiance[c] + 1e-4 * flatRef[i].irradiance[c])
                << "point " << i << " channel " << c;
            EXPECT_LE(std::abs(glS[c] - cutRef[i].glossy[c]), 2.0 * bounds[i].glossy[c] + 1e-4 * flatRef[i].glossy[c])
                << "point " << i << " channel " << c;
            // and the flat GL gather is the flat reference to float rounding (1e-4, as above)
            EXPECT_NEAR(glFlat[c], flatRef[i].irradiance[c], 1e-4 * flatRef[i].irradiance[c] + 1e-12);
        }
        lit += flatRef[i].irradiance.x;
        errorTree += glm::dot(gl - flatRef[i].irradiance, gl - flatRef[i].irradiance);
        errorFlat += glm::dot(glFlat - flatRef[i].irradiance, glFlat - flatRef[i].irradiance);
        norm += glm::dot(flatRef[i].irradiance, flatRef[i].irradiance);
    }
    ASSERT_GT(lit, 0.0);
    // the cut's relative MSE is the price of the threshold: at 0.05 each taken cluster errs by <= 5 % of
    // the estimate; the measured total must stay far below (1e-3 = 3 % RMS)
    EXPECT_LT(errorTree / norm, 1e-3);
    EXPECT_GT(errorTree, errorFlat) << "a cut at 0.05 must differ from the flat gather (else nothing was cut)";
    // Eq. 7's weights, positions and moments of a taken cluster (val_tree_math.glsl) are not bounded; the
    // GL bookkeeping must equal the reference's: where the GL L'_d equals the double cut's to float
    // rounding (the same cut was taken), W_d, sum (l - x) w_d and the moments agree to float rounding too
    // (1e-4 relative of W_d, of W_d x the scene's extent 3 m, of W_d x 9 m^2).
    int sameCut = 0;
    double worstWeight = 0.0;
    for (std::size_t i = 0; i < scene.receivers.size(); ++i) {
        const glm::dvec3 gl(tree.sums[5 * i]);
        worstWeight = std::max(worstWeight, std::abs(double(tree.sums[5 * i + 1].w) - flatRef[i].weightD) /
                                                std::max(flatRef[i].weightD, 1e-30));
        if (glm::length(gl - cutRef[i].irradiance) > 1e-5 * glm::length(cutRef[i].irradiance)) continue;
        ++sameCut;
        const double w = cutRef[i].weightD;
        EXPECT_NEAR(double(tree.sums[5 * i + 1].w), w, 1e-4 * w) << "point " << i;
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(double(tree.sums[5 * i + 1][c]), cutRef[i].offsetD[c], 3e-4 * w) << "point " << i;
            EXPECT_NEAR(double(tree.sums[5 * i + 4][c]), cutRef[i].momentD[c], 9e-4 * w) << "point " << i;
        }
        EXPECT_NEAR(double(tree.sums[5 * i].w), cutRef[i].r2D, 1e-4 * cutRef[i].r2D) << "point " << i;
    }
    EXPECT_GT(sameCut, int(scene.receivers.size()) / 2);
    std::printf(
        "cut %.1f lights and %.1f nodes per point of %zu VALs; relMSE L'_d %.2e (flat GL %.2e); max |W_d| error "
        "vs flat %.3f\n",
        double(tree.choice.valTreeCutPerPoint), double(tree.choice.valTreeVisitedPerPoint), scene.vals.size(),
        errorTree / norm, errorFlat / norm, worstWeight);
}

TEST_F(ValTreeGLTest, CutMatchesTheDoubleWalkAndStaysNearTheFlatGather) { cutMatchesTheDoubleWalk(false); }
// the same with the image quadtree of the VALs' pixel keys (ValSetView::keyWidth), built on the GPU
// (GpuValQuadtree)
TEST_F(ValTreeGLTest, QuadtreeCutMatchesTheDoubleWalkAndStaysNearTheFlatGather) { cutMatchesTheDoubleWalk(true); }

// The CPU backend runs the reference's walk (gi/lightskin/src/ValTreeWalk.h) in double on the same
// points and stores float sums: equal to the reference cut up to that one rounding (6e-8 relative;
// 1e-6 leaves room for the float world transform of the points), at any thread count. With pixel keys
// (CpuValPixelKeys, as FramePipeline passes CpuValGenerator's) the cut goes through the image quadtree:
// it then equals the reference walk of the double quadtree, and not the BVH's cut.
std::vector<glm::vec4> cpuBackendTakesTheReferenceCut(bool quadtree) {
    RoomScene scene;
    const float threshold = 0.05f;
    gi::CpuLightSkinSettings settings;
    settings.lightSkin.valTreeThreshold = threshold;
    const std::uint32_t keyHeight = std::uint32_t(scene.vals.size()) / RoomScene::kKeyWidth;
    const gi::CpuValPixelKeys pixels =
        quadtree ? gi::CpuValPixelKeys{scene.keys, RoomScene::kKeyWidth, keyHeight} : gi::CpuValPixelKeys{};
    std::vector<std::vector<glm::vec4>> sums;
    for (int threads : {1, 2}) {
        settings.threads = threads;
        auto cpu = gi::CpuLightSkin::create(settings, scene.provider());
        cpu->prepare(scene.instances);
        cpu->computeVpls(scene.vals, scene.instances, scene.eye, pixels);
        sums.emplace_back();
        cpu->readGatherSums(sums.back());
        EXPECT_GT(cpu->lastStats().valTreeCutPerPoint, 0.0);
        EXPECT_LT(cpu->lastStats().valTreeCutPerPoint, 0.25 * double(scene.vals.size()));
        EXPECT_EQ(cpu->lastStats().valTreeQuadtree, quadtree);
        scene.receivers = ref::receiversFromSparsePoints(scene.sparsePoints(0), scene.instances[0].world_T_model, 20.0);
    }
    EXPECT_EQ(sums[0], sums[1]) << "the thread count must not change the sums";
    gi::ValTreeD treeD;
    if (quadtree)
        gi::buildValQuadtreeInto(scene.vals, scene.keys, RoomScene::kKeyWidth, keyHeight, treeD);
    else
        gi::buildValTreeInto(scene.vals, treeD);
    std::vector<ref::GatherSums> cutRef;
    ref::GatherParameters parameters;
    parameters.epsilonL = 0.0;
    ref::gatherWithCutInto(treeD, scene.vals, scene.receivers, glm::dvec3(scene.eye), parameters, threshold, cutRef);
    EXPECT_EQ(sums[0].size(), 5 * cutRef.size());
    if (sums[0].size() != 5 * cutRef.size()) return {};
    for (std::size_t i = 0; i < cutRef.size(); ++i)
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(double(sums[0][5 * i][c]), cutRef[i].irradiance[c], 1e-6 * cutRef[i].irradiance[c] + 1e-30)
                << "point " << i;
            EXPECT_NEAR(double(sums[0][5 * i + 2][c]), cutRef[i].glossy[c], 1e-6 * cutRef[i].glossy[c] + 1e-30)
                << "point " << i;
        }
    return sums[0];
}

// valTreeMinVals (gi.valTreeThreshold "auto" on GL): a frame with fewer VALs gathers flat, one with that many cuts.
TEST_F(ValTreeGLTest, MinValsGathersFlatBelowItAndCutsFromIt) {
    RoomScene scene;
    const auto count = std::uint32_t(scene.vals.size());
    const GatherRun flat = scene.run(0.0f, 64, true);
    const GatherRun tree = scene.run(0.05f, 64, true);
    const GatherRun below = scene.run(0.05f, 64, true, count + 1);
    const GatherRun from = scene.run(0.05f, 64, true, count);
    ASSERT_EQ(tree.choice.valTreeNodes, 2 * count - 1) << "the cut ran";
    EXPECT_EQ(below.choice.valTreeNodes, 0u) << "fewer VALs than the minimum: no tree";
    EXPECT_EQ(from.choice.valTreeNodes, tree.choice.valTreeNodes);
    ASSERT_EQ(below.sums.size(), flat.sums.size());
    ASSERT_EQ(from.sums.size(), tree.sums.size());
    std::size_t differFromFlat = 0;
    for (std::size_t i = 0; i < flat.sums.size(); ++i) {
        EXPECT_EQ(below.sums[i], flat.sums[i]) << "sum " << i;
        EXPECT_EQ(from.sums[i], tree.sums[i]) << "sum " << i;
        differFromFlat += tree.sums[i] != flat.sums[i] ? 1u : 0u;
    }
    EXPECT_GT(differFromFlat, flat.sums.size() / 2)
        << "the cut's sums are not the flat gather's: the two are told apart";
}

TEST_F(ValTreeGLTest, CpuBackendTakesTheReferenceCut) {
    const std::vector<glm::vec4> bvh = cpuBackendTakesTheReferenceCut(false);
    const std::vector<glm::vec4> quadtree = cpuBackendTakesTheReferenceCut(true);
    // the two trees cluster differently, so their cuts differ somewhere: else the keys were ignored
    EXPECT_NE(bvh, quadtree);
}

// Keys that are not an image's (a key outside it) are a clear error, not a crash.
TEST_F(ValTreeGLTest, CpuBackendRefusesBadPixelKeys) {
    RoomScene scene;
    gi::CpuLightSkinSettings settings;
    settings.lightSkin.valTreeThreshold = 0.05f;
    auto cpu = gi::CpuLightSkin::create(settings, scene.provider());
    cpu->prepare(scene.instances);
    std::vector<std::uint32_t> keys = scene.keys;
    keys[7] = RoomScene::kKeyWidth * 1000; // beyond the 48 x 144 image
    try {
        cpu->computeVpls(scene.vals, scene.instances, scene.eye, {keys, RoomScene::kKeyWidth, 144});
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("VAL 7"), std::string::npos) << e.what();
    }
}

} // namespace
} // namespace lightskin::test
