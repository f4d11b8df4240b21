// The depth image's VAL quadtree built on the GPU (GpuValQuadtree, gi/lightskin/shaders/val_tree_build.comp)
// against (a) the CPU builder in double (same structure, statistics within float tolerance), (b) the
// exact double statistics of each node's member VALs (the float cone, box and r2Min must bound them:
// the certification of the error bound), and (c) the double reference of the gather with a cut run on
// the GPU tree's own statistics (its error must stay below its certified bound).
#include "GlTestEnvironment.h"
#include "ValTreeScenes.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/lightskin/GpuValQuadtree.h>
#include <lightskin/gi/reference/LightSkinReference.h>
#include <lightskin/gi/lightskin/ValTree.h>
#include <lightskin/gi/reference/ValTreeReference.h>
#include <lightskin/gl/Objects.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>

namespace lightskin::test {
namespace {

namespace ref = gi::reference;
using glm::dvec3;
using ValTreeGpuBuildGLTest = GlTest;

struct GpuTree {
    std::vector<gi::ValCluster> nodes; // nodeSlots() slots, node 0 = root
    std::uint32_t used = 0;            // build()'s return
};

GpuTree buildOnGpu(gi::GpuValQuadtree& builder, const std::vector<gi::VirtualAreaLight>& vals, const ImageKeys& image) {
    const gl::Buffer valBuffer =
        gl::Buffer::create(GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)), vals.data());
    const gl::Buffer keyBuffer = gl::Buffer::create(GLsizeiptr(image.keys.size() * 4), image.keys.data());
    GpuTree t;
    t.used = builder.build(gi::ValSetView{valBuffer.id(), std::uint32_t(vals.size()), 0, keyBuffer.id(),
                                          image.width * image.height, image.width});
    builder.readNodes(t.nodes);
    return t;
}

// The exact angle between two directions in double: 2 asin(chord / 2), accurate to ~1e-16 rad near 0
// (unlike acos of a dot product).
double exactAngle(const dvec3& a, const dvec3& b) {
    return 2.0 * std::asin(std::min(glm::length(glm::normalize(a) - glm::normalize(b)) / 2.0, 1.0));
}

// Walks the GPU tree and the CPU tree together; returns the VAL indices below the GPU node.
struct Comparison {
    const std::vector<gi::VirtualAreaLight>& vals;
    const GpuTree& gpu;
    const gi::ValTreeD& cpu;
    std::string scene;
    int nodes = 0, structureErrors = 0, looseCones = 0;
    double worstConeRatio = 0.0; // GPU cone / CPU cone, inner nodes with a CPU cone > 1e-3

    std::vector<std::uint32_t> walk(std::uint32_t g, std::uint32_t c) {
        ++nodes;
        if (g >= gpu.nodes.size() || c >= cpu.nodes.size()) {
            ADD_FAILURE() << scene << ": child index out of range (GPU " << g << ", CPU " << c << ")";
            ++structureErrors;
            return {};
        }
        const gi::ValCluster& n = gpu.nodes[g];
        const gi::ValClusterD& d = cpu.nodes[c];
        std::vector<std::uint32_t> members;
        const bool leaf = n.child1 == gi::kValTreeLeaf;
        if (leaf != (d.child1 == gi::kValTreeLeaf) || (leaf && n.child0 != d.child0)) {
            ADD_FAILURE() << scene << ": GPU node " << g << " and CPU node " << c << " differ in structure";
            ++structureErrors;
            return {};
        }
        if (leaf) {
            members.push_back(n.child0);
        } else {
            members = walk(n.child0, d.child0);
            const std::vector<std::uint32_t> b = walk(n.child1, d.child1);
            members.insert(members.end(), b.begin(), b.end());
        }
        checkCertified(n, members, g);
        checkAgainstCpu(n, d, g);
        return members;
    }

    // (b) The stored float statistics bound the exact ones of the members, strictly (no tolerance):
    // cone angle around the stored axis, box, r2Min; the representative inside the box, r2Mean >=
    // r2Min, normalScale <= 1 (val_tree_math.glsl's premises).
    void checkCertified(const gi::ValCluster& n, const std::vector<std::uint32_t>& members, std::uint32_t g) {
        const dvec3 axis(n.axis);
        for (std::uint32_t j : members) {
            const gi::VirtualAreaLight& l = vals[j];
            if (glm::length(dvec3(l.normal)) > 0.0) {
                EXPECT_LE(exactAngle(axis, dvec3(l.normal)), double(n.coneAngle))
                    << scene << " node " << g << " member " << j;
            }
            for (int a = 0; a < 3; ++a) {
                EXPECT_LE(n.boxMin[a], l.position[a]) << scene << " node " << g << " member " << j;
                EXPECT_GE(n.boxMax[a], l.position[a]) << scene << " node " << g << " member " << j;
            }
            EXPECT_LE(double(n.r2Min), double(l.area) / std::numbers::pi) << scene << " node " << g << " member " << j;
        }
        EXPECT_EQ(double(n.count), double(members.size())) << scene << " node " << g;
        EXPECT_GE(n.r2Mean, n.r2Min) << scene << " node " << g;
        EXPECT_LE(n.normalScale, 1.0f) << scene << " node " << g;
        for (int a = 0; a < 3; ++a) {
            EXPECT_GE(n.position[a], n.boxMin[a]) << scene << " node " << g;
            EXPECT_LE(n.position[a], n.boxMax[a]) << scene << " node " << g;
        }
    }

    // (a) Float against double combination. Tolerances: a node sums <= 2 n - 1 values along <= 30
    // levels (ImageKeys' images are below 2^15 pixels), each float operation within 6e-8 relative
    // (correctly rounded, the sums of positive terms), so flux and r2 sums within 30 x 4 x 6e-8 =
    // 7.2e-6 relative: 1e-5. Positions are means of coordinates within 2 m (the scenes): 1e-5 x 2 m
    // = 2e-5 m. Variances: (d + e)^2 - d^2 with |d| <= 4 m and e <= 2e-5 m: 1.6e-4 m^2, 2e-4.
    // The axis: rounding of sum phi_j n_j (1e-5 relative of sum phi_j as above) turns it by 1e-5 /
    // normalScale rad. Cones: the GPU's bound of each angle is <= 4 / pi = 1.27x the angle (the
    // tangent bound of val_tree_build.comp) plus 2 x 2^-16 rad, per level: <= 1.28 x the CPU's
    // (whose angles are exact) + 30 x 3.1e-5 rad (< 1e-3), capped at pi.
    void checkAgainstCpu(const gi::ValCluster& n, const gi::ValClusterD& d, std::uint32_t g) {
        for (int a = 0; a < 3; ++a) {
            EXPECT_NEAR(double(n.flux[a]), d.flux[a], 1e-5 * std::abs(d.flux[a]) + 1e-30) << scene << " node " << g;
            EXPECT_NEAR(double(n.position[a]), d.position[a], 2e-5) << scene << " node " << g;
            EXPECT_NEAR(double(n.variance[a]), d.variance[a], 2e-4 + 1e-5 * d.variance[a]) << scene << " node " << g;
        }
        EXPECT_NEAR(double(n.r2Sum), d.r2Sum, 1e-5 * d.r2Sum) << scene << " node " << g;
        EXPECT_NEAR(double(n.r2Mean), d.r2Mean, 1e-5 * d.r2Mean) << scene << " node " << g;
        EXPECT_NEAR(double(n.normalScale), d.normalScale, 1e-5) << scene << " node " << g;
        if (d.normalScale > 1e-3) {
            EXPECT_LE(exactAngle(dvec3(n.axis), d.axis), 1e-5 / d.normalScale + 1e-6) << scene << " node " << g;
        }
        const double coneLimit = std::min(std::numbers::pi, 1.28 * d.coneAngle + 1e-3);
        if (double(n.coneAngle) > coneLimit) ++looseCones;
        EXPECT_LE(double(n.coneAngle), coneLimit + 1e-6) << scene << " node " << g << " CPU cone " << d.coneAngle;
        if (n.child1 != gi::kValTreeLeaf && d.coneAngle > 1e-3)
            worstConeRatio = std::max(worstConeRatio, double(n.coneAngle) / d.coneAngle);
    }
};

// The scenes of ValTreeTest plus the room with holes: every 10th VAL invalid (area 0), one NaN area.
std::vector<ValTreeScene> scenes() {
    std::vector<ValTreeScene> s = valTreeScenes();
    ValTreeScene holes = roomScene();
    holes.name = "room_holes";
    for (std::size_t i = 0; i < holes.vals.size(); i += 10) holes.vals[i].area = 0.0f;
    holes.vals[5].area = std::numeric_limits<float>::quiet_NaN();
    s.push_back(std::move(holes));
    return s;
}

std::size_t validCount(const std::vector<gi::VirtualAreaLight>& vals) {
    return std::size_t(std::count_if(vals.begin(), vals.end(), [](const auto& l) { return l.area > 0.0f; }));
}

TEST_F(ValTreeGpuBuildGLTest, GpuQuadtreeIsTheCpuQuadtreeAndBoundsItsMembers) {
    gi::GpuValQuadtree builder = gi::GpuValQuadtree::create();
    for (const ValTreeScene& scene : scenes()) {
        const ImageKeys image = imageKeys(scene.vals);
        const GpuTree gpu = buildOnGpu(builder, scene.vals, image);
        gi::ValTreeD cpu;
        gi::buildValQuadtreeInto(scene.vals, image.keys, image.width, image.height, cpu);
        const std::size_t n = validCount(scene.vals);
        ASSERT_EQ(gpu.used, 2 * n - 1) << scene.name;
        ASSERT_EQ(cpu.nodes.size(), 2 * n - 1) << scene.name;
        Comparison comparison{scene.vals, gpu, cpu, scene.name};
        const std::vector<std::uint32_t> all = comparison.walk(0, 0);
        EXPECT_EQ(comparison.structureErrors, 0) << scene.name;
        EXPECT_EQ(all.size(), n) << scene.name << ": every valid VAL once";
        EXPECT_EQ(comparison.nodes, int(2 * n - 1)) << scene.name;
        std::printf("%-11s %6zu VALs: %d nodes equal in structure; GPU cone / CPU cone <= %.3f\n", scene.name.c_str(),
                    n, comparison.nodes, comparison.worstConeRatio);
    }
}

// (c) The cut through the GPU-built tree, evaluated in double on the tree's own float statistics: its
// error against the flat gather stays below its certified bound at every receiver, channel and
// threshold (as ValTreeTest's ErrorStaysBelowTheCertifiedBound for the CPU trees), plus double
// rounding of both sums (1e-11 relative, as there). A cone that is too small fails here.
TEST_F(ValTreeGpuBuildGLTest, CutThroughTheGpuTreeStaysBelowItsBound) {
    gi::GpuValQuadtree builder = gi::GpuValQuadtree::create();
    for (const ValTreeScene& scene : scenes()) {
        const ImageKeys image = imageKeys(scene.vals);
        const gi::ValTreeD tree = widenValTree(buildOnGpu(builder, scene.vals, image).nodes);
        std::vector<ref::GatherSums> flat, cut;
        std::vector<ref::CutBound> bounds;
        ref::gatherInto(scene.vals, scene.receivers, kValTreeEye, {}, flat);
        for (double threshold : {0.01, 0.1}) {
            ref::CutStatistics stats;
            ref::gatherWithCutInto(tree, scene.vals, scene.receivers, kValTreeEye, {}, threshold, cut, &bounds, &stats);
            ASSERT_EQ(cut.size(), flat.size());
            double lit = 0.0;
            for (std::size_t i = 0; i < flat.size(); ++i) {
                lit += flat[i].irradiance.x;
                for (int c = 0; c < 3; ++c) {
                    EXPECT_LE(std::abs(cut[i].irradiance[c] - flat[i].irradiance[c]),
                              bounds[i].irradiance[c] + 1e-11 * flat[i].irradiance[c])
                        << scene.name << " threshold " << threshold << " receiver " << i;
                    EXPECT_LE(std::abs(cut[i].glossy[c] - flat[i].glossy[c]),
                              bounds[i].glossy[c] + 1e-11 * flat[i].glossy[c])
                        << scene.name << " threshold " << threshold << " receiver " << i;
                }
            }
            EXPECT_GT(lit, 0.0) << scene.name;
            // the cut must cut: fewer than half of the VALs per receiver (else the bound is trivially met)
            const double perReceiver = double(stats.clusters + stats.skipped + stats.leaves) / double(flat.size());
            EXPECT_LT(perReceiver, 0.5 * double(scene.vals.size())) << scene.name << " threshold " << threshold;
        }
    }
}

// A key outside the image and two VALs on one pixel are clear errors naming a VAL, not a crash; an
// all-invalid set gives an empty tree, and the builder is reusable after each.
TEST_F(ValTreeGpuBuildGLTest, BadKeysAreClearErrorsAndEmptySetsEmptyTrees) {
    gi::GpuValQuadtree builder = gi::GpuValQuadtree::create();
    ValTreeScene scene = roomScene();
    ImageKeys image = imageKeys(scene.vals);
    ImageKeys outside = image;
    outside.keys[9] = image.width * image.height; // one past the last pixel
    ImageKeys shared = image;
    shared.keys[12] = shared.keys[11];
    for (const ImageKeys* bad : {&outside, &shared}) {
        try {
            buildOnGpu(builder, scene.vals, *bad);
            ADD_FAILURE() << "no error";
        } catch (const Error& e) {
            const std::string what = e.what();
            EXPECT_NE(what.find(bad == &outside ? "VAL 9" : "VAL 1"), std::string::npos) << what;
            EXPECT_NE(what.find("VAL keys"), std::string::npos) << what;
        }
    }
    EXPECT_EQ(buildOnGpu(builder, scene.vals, image).used, 2 * scene.vals.size() - 1);
    for (auto& l : scene.vals) l.area = 0.0f;
    EXPECT_EQ(buildOnGpu(builder, scene.vals, image).used, 0u);
}

} // namespace
} // namespace lightskin::test
