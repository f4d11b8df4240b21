// The VAL cluster tree (ValTree.h) and the gather with a cut (ValTreeReference.h): the tree's
// invariants checked member by member, threshold 0 against the flat double gather, the measured error
// of a cut against its certified bound on every scene, and the extremes of the issue.
#include "common/GatherTestScenes.h"
#include "ValTreeScenes.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/reference/LightSkinReference.h>
#include <lightskin/gi/lightskin/ValTree.h>
#include <lightskin/gi/reference/ValTreeReference.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>

namespace lightskin::test {
namespace {

namespace ref = gi::reference;
using glm::dvec3;
using glm::vec3;

using Scene = ValTreeScene;
std::vector<Scene> scenes() { return valTreeScenes(); }
const dvec3& kEye = kValTreeEye;

// The two builders of ValTree.h; every property below must hold for both.
enum class Builder { Bvh, Quadtree };
template <class Real>
void buildTree(const std::vector<gi::VirtualAreaLight>& vals, Builder builder, gi::ValTreeT<Real>& tree) {
    if (builder == Builder::Bvh) {
        gi::buildValTreeInto(vals, tree);
    } else {
        const ImageKeys image = imageKeys(vals);
        gi::buildValQuadtreeInto(vals, image.keys, image.width, image.height, tree);
    }
}

// Relative difference with an absolute floor `scale` (the receiver's own magnitude).
double relative(double a, double b, double scale) { return std::abs(a - b) / std::max(scale, 1e-300); }

void clustersHoldTheirVals(Builder builder) {
    for (const Scene& scene : scenes()) {
        gi::ValTreeD tree;
        buildTree(scene.vals, builder, tree);
        gi::ValTree treeF;
        buildTree(scene.vals, builder, treeF);
        ASSERT_EQ(tree.nodes.size(), 2 * scene.vals.size() - 1) << scene.name;
        ASSERT_EQ(treeF.nodes.size(), tree.nodes.size()) << scene.name;
        if (builder == Builder::Bvh) { // median split: depth ceil(log2 n) + 1 exactly
            EXPECT_EQ(tree.depth, int(std::ceil(std::log2(double(scene.vals.size())))) + 1) << scene.name;
        } else { // one binary level per halving of a side, plus the leaves; carries add none
            const ImageKeys image = imageKeys(scene.vals);
            EXPECT_LE(tree.depth, int(std::ceil(std::log2(double(image.width)))) +
                                      int(std::ceil(std::log2(double(image.height)))) + 1)
                << scene.name;
            EXPECT_GE(tree.depth, int(std::ceil(std::log2(double(scene.vals.size())))) + 1) << scene.name;
        }
        // The root against totals summed here; every node against its member VALs (walked here).
        dvec3 flux(0.0);
        for (const auto& l : scene.vals) flux += dvec3(l.flux);
        EXPECT_LT(glm::length(tree.nodes[0].flux - flux), 1e-12 * glm::length(flux)) << scene.name;
        EXPECT_EQ(tree.nodes[0].count, double(scene.vals.size()));
        std::vector<std::uint32_t> members;
        for (std::size_t node = 0; node < tree.nodes.size(); node += 97) { // a sample of nodes of all sizes
            members.clear();
            std::vector<std::uint32_t> stack{std::uint32_t(node)};
            while (!stack.empty()) {
                const auto& c = tree.nodes[stack.back()];
                stack.pop_back();
                if (c.child1 == gi::kValTreeLeaf)
                    members.push_back(c.child0);
                else
                    stack.insert(stack.end(), {c.child0, c.child1});
            }
            const auto& c = tree.nodes[node];
            const auto& f = treeF.nodes[node];
            ASSERT_EQ(double(members.size()), c.count);
            for (std::uint32_t j : members) {
                const auto& l = scene.vals[j];
                for (int a = 0; a < 3; ++a) {
                    EXPECT_LE(f.boxMin[a], l.position[a]); // float boxes rounded outward
                    EXPECT_GE(f.boxMax[a], l.position[a]);
                }
                const double angle =
                    std::acos(std::clamp(glm::dot(c.axis, glm::normalize(dvec3(l.normal))), -1.0, 1.0));
                // acos(1 - eps) = sqrt(2 eps) = 2.1e-8 in double: the builder and this check each round so much
                EXPECT_LE(angle, c.coneAngle + 5e-8) << scene.name << " node " << node;
                EXPECT_LE(f.r2Min, double(l.area) / std::numbers::pi);
            }
            for (int a = 0; a < 3; ++a) {
                EXPECT_GE(c.position[a], c.boxMin[a] - 1e-12);
                EXPECT_LE(c.position[a], c.boxMax[a] + 1e-12);
            }
            EXPECT_GE(c.r2Mean, c.r2Min);
            EXPECT_LE(c.normalScale, 1.0);
        }
    }
}

TEST(ValTree, InvalidValsAreLeftOutAndEmptySetsGiveEmptyTrees) {
    std::vector<gi::VirtualAreaLight> vals(3, disc({0, 0, 1}, {0, 0, -1}, 0.01f, vec3(1.0f)));
    vals[1].area = 0.0f;
    vals[2].area = std::nanf("");
    gi::ValTreeD tree;
    gi::buildValTreeInto(vals, tree);
    ASSERT_EQ(tree.nodes.size(), 1u);
    EXPECT_EQ(tree.nodes[0].child0, 0u);
    gi::buildValTreeInto(std::span(vals).subspan(1), tree);
    EXPECT_TRUE(tree.nodes.empty());
    std::vector<ref::GatherSums> out;
    const auto receivers = sphereReceivers({0, 0, 0}, 2, 4);
    ref::gatherWithCutInto(tree, std::span(vals).subspan(1), receivers, kEye, {}, 0.1, out);
    ASSERT_EQ(out.size(), receivers.size());
    for (const auto& s : out) EXPECT_EQ(s.weightD, 0.0);
}

// Threshold 0 takes only clusters that add exactly nothing, so every sum is the flat gather's up to the
// order of the additions: double rounding, n * 1.1e-16 relative for n VALs (<= 12288: 1.4e-12) of the
// sum of magnitudes; all terms are >= 0 except the offsets, bounded by the weights times the scene's
// extent (4 m), so 1e-11 of that scale covers it.
void thresholdZeroIsTheFlatGather(Builder builder) {
    for (const Scene& scene : scenes()) {
        gi::ValTreeD tree;
        buildTree(scene.vals, builder, tree);
        std::vector<ref::GatherSums> flat, cut;
        std::vector<ref::CutBound> bounds;
        ref::GatherParameters parameters;
        parameters.epsilonL = 0.0; // eps terms placed at cluster means are tested below
        ref::gatherInto(scene.vals, scene.receivers, kEye, parameters, flat);
        ref::CutStatistics stats;
        ref::gatherWithCutInto(tree, scene.vals, scene.receivers, kEye, parameters, 0.0, cut, &bounds, &stats);
        EXPECT_EQ(stats.clusters, 0u) << scene.name;
        double lit = 0.0;
        for (std::size_t i = 0; i < flat.size(); ++i) {
            const auto &a = flat[i], &b = cut[i];
            lit += a.irradiance.x;
            for (int c = 0; c < 3; ++c) {
                EXPECT_LE(relative(a.irradiance[c], b.irradiance[c], a.irradiance[c]), 1e-11) << scene.name << " " << i;
                EXPECT_LE(relative(a.glossy[c], b.glossy[c], a.glossy[c]), 1e-11) << scene.name << " " << i;
                EXPECT_LE(relative(a.offsetD[c], b.offsetD[c], 4.0 * a.weightD), 1e-11) << scene.name << " " << i;
                EXPECT_LE(relative(a.momentD[c], b.momentD[c], a.momentD[c]), 1e-11) << scene.name << " " << i;
            }
            EXPECT_LE(relative(a.weightD, b.weightD, a.weightD), 1e-11) << scene.name << " " << i;
            EXPECT_LE(relative(a.weightS, b.weightS, a.weightS), 1e-11) << scene.name << " " << i;
            EXPECT_LE(relative(a.r2D, b.r2D, a.r2D), 1e-11) << scene.name << " " << i;
            EXPECT_EQ(bounds[i].irradiance, dvec3(0.0));
        }
        EXPECT_GT(lit, 0.0) << scene.name << ": the scene must light its receivers";
        // the horizon and back-face skips must be taken (else threshold 0 proves nothing about them)
        if (scene.name != "contact") { // contact: every VAL faces every receiver
            EXPECT_GT(stats.skipped, 0u) << scene.name;
        }
    }
}

// Every cut's error against the flat gather is below its certified bound (sum of U over taken
// clusters), per channel, for L'_d and L'_s; plus double rounding of both sums (1e-11 relative, as above).
// nearField: guard G12 (near-field VALs as areas, beyond eq. 3's bound): the cut must leave every
// cluster within its members' near field unopened (val_tree_math.glsl), so the bound still holds.
void errorStaysBelowTheCertifiedBound(Builder builder, bool nearField = false) {
    ref::GatherParameters parameters;
    parameters.nearField = nearField;
    for (const Scene& scene : scenes()) {
        gi::ValTreeD tree;
        buildTree(scene.vals, builder, tree);
        std::vector<ref::GatherSums> flat, cut;
        std::vector<ref::CutBound> bounds;
        ref::gatherInto(scene.vals, scene.receivers, kEye, parameters, flat);
        for (double threshold : {0.001, 0.01, 0.1, 1.0}) {
            ref::CutStatistics stats;
            ref::gatherWithCutInto(tree, scene.vals, scene.receivers, kEye, parameters, threshold, cut, &bounds,
                                   &stats);
            double worstRatio = 0.0;
            for (std::size_t i = 0; i < flat.size(); ++i) {
                for (int c = 0; c < 3; ++c) {
                    const double errD = std::abs(cut[i].irradiance[c] - flat[i].irradiance[c]);
                    const double errS = std::abs(cut[i].glossy[c] - flat[i].glossy[c]);
                    EXPECT_LE(errD, bounds[i].irradiance[c] + 1e-11 * flat[i].irradiance[c])
                        << scene.name << " threshold " << threshold << " receiver " << i;
                    EXPECT_LE(errS, bounds[i].glossy[c] + 1e-11 * flat[i].glossy[c])
                        << scene.name << " threshold " << threshold << " receiver " << i;
                    if (bounds[i].irradiance[c] > 0.0)
                        worstRatio = std::max(worstRatio, errD / bounds[i].irradiance[c]);
                }
            }
            // the cut must really cut: fewer than half of the VALs per receiver at threshold >= 0.01
            const double perReceiver = double(stats.clusters + stats.skipped + stats.leaves) / double(flat.size());
            if (threshold >= 0.01) {
                EXPECT_LT(perReceiver, 0.5 * double(scene.vals.size())) << scene.name;
            }
            std::printf("%-10s threshold %-6g nodes visited per receiver %9.1f of %zu VALs, worst error/bound %.3f\n",
                        scene.name.c_str(), threshold, double(stats.visited) / double(flat.size()), scene.vals.size(),
                        worstRatio);
        }
    }
}

// The bound holds for every cluster, not only in sums: for receivers of each scene and every node of
// the tree, U >= the exact sum over the node's members (gathered here VAL by VAL with the flat
// reference) and U >= the cluster's approximation (a one-node tree with the same statistics, taken
// whole). A bound that leaves out a term (the slack, beta, the cone angle, r2Min) fails here.
// 1e-12: double rounding of the sums over <= 12288 VALs (1.4e-12 relative would be the worst case of
// n eps; the sums are of positive terms, whose relative error is far below it).
void boundHoldsForEveryCluster(Builder builder) {
    for (const Scene& scene : scenes()) {
        gi::ValTreeD tree;
        buildTree(scene.vals, builder, tree);
        std::vector<gi::VirtualAreaLight> members;
        std::vector<ref::GatherSums> exact;
        int tight = 0, checked = 0;
        for (std::size_t r = 0; r < scene.receivers.size(); r += 5) {
            const std::span<const ref::Receiver> one(&scene.receivers[r], 1);
            for (std::size_t node = 0; node < tree.nodes.size(); node += 13) {
                members.clear();
                std::vector<std::uint32_t> stack{std::uint32_t(node)};
                while (!stack.empty()) {
                    const auto& c = tree.nodes[stack.back()];
                    stack.pop_back();
                    if (c.child1 == gi::kValTreeLeaf) {
                        members.push_back(scene.vals[c.child0]);
                    } else {
                        stack.insert(stack.end(), {c.child0, c.child1});
                    }
                }
                if (members.size() < 2) continue;
                const auto& c = tree.nodes[node];
                const ref::CutBound u = ref::clusterErrorBound(c, scene.receivers[r], kEye, {});
                ref::gatherInto(members, one, kEye, {}, exact);
                const ref::GatherSums approx = ref::clusterAsOneLight(c, scene.receivers[r], kEye, {});
                for (int ch = 0; ch < 3; ++ch) {
                    EXPECT_LE(exact[0].irradiance[ch], u.irradiance[ch] * (1.0 + 1e-12))
                        << scene.name << " receiver " << r << " node " << node;
                    EXPECT_LE(exact[0].glossy[ch], u.glossy[ch] * (1.0 + 1e-12))
                        << scene.name << " receiver " << r << " node " << node;
                    EXPECT_LE(approx.irradiance[ch], u.irradiance[ch] * (1.0 + 1e-12))
                        << scene.name << " receiver " << r << " node " << node;
                    EXPECT_LE(approx.glossy[ch], u.glossy[ch] * (1.0 + 1e-12))
                        << scene.name << " receiver " << r << " node " << node;
                    if (exact[0].irradiance[ch] > 0.5 * u.irradiance[ch]) ++tight;
                }
                ++checked;
            }
        }
        // the bound must not be vacuous everywhere: some clusters reach half of it (not in contact, where
        // every VAL is within 1 mm of a receiver's plane: cos(theta_i) of most is far below its bound)
        if (scene.name != "contact") {
            EXPECT_GT(tight, 0) << scene.name << " (" << checked << " clusters)";
        }
    }
}

TEST(ValTree, ClustersHoldTheirVals) { clustersHoldTheirVals(Builder::Bvh); }
TEST(ValQuadtree, ClustersHoldTheirVals) { clustersHoldTheirVals(Builder::Quadtree); }
TEST(ValTreeCut, ThresholdZeroIsTheFlatGather) { thresholdZeroIsTheFlatGather(Builder::Bvh); }
TEST(ValQuadtreeCut, ThresholdZeroIsTheFlatGather) { thresholdZeroIsTheFlatGather(Builder::Quadtree); }
TEST(ValTreeCut, ErrorStaysBelowTheCertifiedBound) { errorStaysBelowTheCertifiedBound(Builder::Bvh); }
TEST(ValQuadtreeCut, ErrorStaysBelowTheCertifiedBound) { errorStaysBelowTheCertifiedBound(Builder::Quadtree); }
TEST(ValTreeCut, ErrorStaysBelowTheCertifiedBoundWithNearFieldAreas) {
    errorStaysBelowTheCertifiedBound(Builder::Bvh, true);
}
TEST(ValTreeCut, BoundHoldsForEveryCluster) { boundHoldsForEveryCluster(Builder::Bvh); }
TEST(ValQuadtreeCut, BoundHoldsForEveryCluster) { boundHoldsForEveryCluster(Builder::Quadtree); }

// Every pixel of the image visited: the quadtree of a full W x H grid of VALs (keys = pixel order) is
// a complete image pyramid; each node's members form one axis-aligned block of pixels of the size its
// level says (2^a x 2^b, cut by the image border), so a builder that pairs the wrong neighbours fails.
TEST(ValQuadtree, NodesAreImageBlocks) {
    const std::uint32_t width = 13, height = 6; // not powers of two: border cells carry single children
    std::vector<gi::VirtualAreaLight> vals;
    std::vector<std::uint32_t> keys;
    for (std::uint32_t v = 0; v < height; ++v)
        for (std::uint32_t u = 0; u < width; ++u) {
            // the pixel at (u, v) sits at (u, v, 0) in the world, so members can be checked by position
            vals.push_back(disc({float(u), float(v), 0.0f}, {0, 0, 1}, 0.01f, vec3(1.0f)));
            keys.push_back(v * width + u);
        }
    // a shuffled VAL order (ValGenerator appends through an atomic counter): the tree must not depend on it
    std::vector<std::size_t> perm(vals.size());
    for (std::size_t i = 0; i < perm.size(); ++i) perm[i] = (i * 37) % perm.size(); // 37 coprime to 78
    std::vector<gi::VirtualAreaLight> shuffled;
    std::vector<std::uint32_t> shuffledKeys;
    for (std::size_t i : perm) {
        shuffled.push_back(vals[i]);
        shuffledKeys.push_back(keys[i]);
    }
    gi::ValTreeD tree;
    gi::buildValQuadtreeInto(shuffled, shuffledKeys, width, height, tree);
    ASSERT_EQ(tree.nodes.size(), 2 * vals.size() - 1);
    EXPECT_EQ(tree.depth, 4 + 3 + 1); // ceil(log2 13) + ceil(log2 6) + 1
    for (std::size_t node = 0; node < tree.nodes.size(); ++node) {
        const auto& c = tree.nodes[node];
        if (c.child1 == gi::kValTreeLeaf) continue;
        // the two children: disjoint blocks that touch along u or v (neighbours in the image)
        const auto &a = tree.nodes[c.child0], &b = tree.nodes[c.child1];
        EXPECT_GT(c.child0, node); // children after their parent (reversed creation order)
        EXPECT_GT(c.child1, node);
        const bool alongU = a.boxMin.y == b.boxMin.y && a.boxMax.y == b.boxMax.y && b.boxMin.x == a.boxMax.x + 1.0;
        const bool alongV = a.boxMin.x == b.boxMin.x && a.boxMax.x == b.boxMax.x && b.boxMin.y == a.boxMax.y + 1.0;
        EXPECT_TRUE(alongU || alongV) << "node " << node;
        // a full block: the box holds exactly `count` pixels
        const dvec3 extent = c.boxMax - c.boxMin + dvec3(1.0);
        EXPECT_EQ(extent.x * extent.y, c.count) << "node " << node;
        // the block is aligned to its size (Morton): a block of 2^k pixels along u starts at a multiple of 2^k
        const double sizeU = std::exp2(std::ceil(std::log2(extent.x)));
        const double sizeV = std::exp2(std::ceil(std::log2(extent.y)));
        EXPECT_EQ(std::fmod(c.boxMin.x, sizeU), 0.0) << "node " << node;
        EXPECT_EQ(std::fmod(c.boxMin.y, sizeV), 0.0) << "node " << node;
        // quadtree, not strips: pairing alternates u and v, so a block not cut by the border is square or
        // twice as wide as high (once v is exhausted at 8 rows, only wider)
        const bool cut = c.boxMax.x == width - 1.0 || c.boxMax.y == height - 1.0;
        if (!cut && sizeV < 8.0) {
            EXPECT_TRUE(sizeU == sizeV || sizeU == 2.0 * sizeV) << "node " << node << ": " << sizeU << "x" << sizeV;
        }
    }
}

TEST(ValQuadtree, EmptyAndInvalidPixelsAddNoNodes) {
    std::vector<gi::VirtualAreaLight> vals(4, disc({0, 0, 1}, {0, 0, -1}, 0.01f, vec3(1.0f)));
    vals[1].area = 0.0f;
    vals[2].area = std::nanf("");
    const std::vector<std::uint32_t> keys{5, 6, 7, 40};
    gi::ValTreeD tree;
    gi::buildValQuadtreeInto(vals, keys, 8, 8, tree);
    ASSERT_EQ(tree.nodes.size(), 3u); // VALs 0 and 3: one pair, the rest of the 64 pixels carry nothing
    EXPECT_EQ(tree.nodes[0].count, 2.0);
    EXPECT_EQ(tree.depth, 2);
    gi::buildValQuadtreeInto(std::span(vals).subspan(1, 2), std::span(keys).subspan(1, 2), 8, 8, tree);
    EXPECT_TRUE(tree.nodes.empty());
    EXPECT_EQ(tree.depth, 0);
}

TEST(ValQuadtree, BadKeysAreClearErrors) {
    const std::vector<gi::VirtualAreaLight> vals(2, disc({0, 0, 1}, {0, 0, -1}, 0.01f, vec3(1.0f)));
    gi::ValTree tree;
    const std::vector<std::uint32_t> outside{0, 64}, shared{3, 3};
    EXPECT_THROW(gi::buildValQuadtreeInto(vals, outside, 8, 8, tree), Error);
    try {
        gi::buildValQuadtreeInto(vals, shared, 8, 8, tree);
        ADD_FAILURE() << "two VALs in one pixel must throw";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("share pixel 3"), std::string::npos) << e.what();
    }
}

TEST(ValTreeCut, OneValIsExact) {
    const std::vector<gi::VirtualAreaLight> vals{disc({0, 0, 1}, {0, 0, -1}, 0.01f, vec3(1.0f, 2.0f, 3.0f))};
    gi::ValTreeD tree;
    gi::buildValTreeInto(vals, tree);
    const auto receivers = sphereReceivers({0, 0, 0}, 4, 6);
    std::vector<ref::GatherSums> flat, cut;
    ref::gatherInto(vals, receivers, kEye, {}, flat);
    ref::gatherWithCutInto(tree, vals, receivers, kEye, {}, 1e300, cut);
    for (std::size_t i = 0; i < flat.size(); ++i) {
        EXPECT_EQ(flat[i].irradiance, cut[i].irradiance); // one leaf: the same formula, the same order
        EXPECT_EQ(flat[i].weightD, cut[i].weightD);
        EXPECT_EQ(flat[i].momentD, cut[i].momentD);
    }
}

// All VALs in one depth pixel (same position, different normals and fluxes): the cluster has a zero box;
// the bound must still hold and the approximation must keep the total.
TEST(ValTreeCut, AllValsInOnePixel) {
    std::vector<gi::VirtualAreaLight> vals;
    for (int i = 0; i < 64; ++i) {
        const float t = float(i) / 64.0f;
        vals.push_back(disc({0.2f, 0.1f, 1.0f}, glm::normalize(vec3(0.3f * t, -0.2f, -1.0f)), 1e-4f * (1.0f + t),
                            vec3(1.0f + t, 1.0f, 2.0f - t) * 1e-4f));
    }
    gi::ValTreeD tree;
    gi::buildValTreeInto(vals, tree);
    EXPECT_EQ(tree.nodes[0].boxMin, tree.nodes[0].boxMax);
    const auto receivers = sphereReceivers({0, 0, 0}, 6, 8);
    std::vector<ref::GatherSums> flat, cut;
    std::vector<ref::CutBound> bounds;
    ref::gatherInto(vals, receivers, kEye, {}, flat);
    ref::gatherWithCutInto(tree, vals, receivers, kEye, {}, 0.05, cut, &bounds);
    for (std::size_t i = 0; i < flat.size(); ++i) {
        for (int c = 0; c < 3; ++c) {
            EXPECT_LE(std::abs(cut[i].irradiance[c] - flat[i].irradiance[c]),
                      bounds[i].irradiance[c] + 1e-11 * flat[i].irradiance[c]);
        }
    }
}

} // namespace
} // namespace lightskin::test
