// Linear blend skinning of a glTF skin (render/Skinning.h) against the closed form of bending_cylinder.gltf
// (scripts/make_gltf_samples.py), and sparse points anchored to the surface (gi::followSurfaceInto) following it.
#include "TestPaths.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/common/SparsePointSampler.h>
#include <lightskin/render/MeshLoader.h>
#include <lightskin/render/Skinning.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

using namespace lightskin;
using namespace lightskin::render;

namespace {

std::filesystem::path cylinderFile() { return test::dataPath("meshes") / "bending_cylinder.gltf"; }

// The sample's truth: a vertex at height y weighs the upper bone w(y) = clamp((y - 0.75) / 0.5, 0, 1); the upper bone
// turns about +z through the joint J = [0, 1, 0] by 90 t degrees (t in [0, 1] s, held after).
constexpr glm::dvec3 kJoint(0.0, 1.0, 0.0);
double upperWeight(double y) { return std::clamp((y - 0.75) / 0.5, 0.0, 1.0); }
glm::dvec3 rotateZ(const glm::dvec3& p, double angle) {
    return {std::cos(angle) * p.x - std::sin(angle) * p.y, std::sin(angle) * p.x + std::cos(angle) * p.y, p.z};
}
double bendAngle(double t) { return glm::radians(90.0) * std::clamp(t, 0.0, 1.0); }
glm::dvec3 skinnedClosedForm(const glm::dvec3& p, double t) {
    const double w = upperWeight(p.y);
    return (1.0 - w) * p + w * (kJoint + rotateZ(p - kJoint, bendAngle(t)));
}
glm::dvec3 skinnedNormalClosedForm(const glm::dvec3& p, const glm::dvec3& n, double t) {
    const double w = upperWeight(p.y);
    return glm::normalize((1.0 - w) * n + w * rotateZ(n, bendAngle(t)));
}

// Float: coordinates are below 2.2 m (ulp 2.4e-7 m) and each skinned one is two 4x4 products and a blend, some ten
// roundings: < 3e-6 m. 1e-5 m (and 1e-5 for unit normals) is above that and far below what a wrong weight, bone or
// offset order moves (centimetres: the bend turns the upper half by up to 1.57 rad about a joint 1 m away).
constexpr double kTolerance = 1e-5;

void expectNear(const glm::vec3& actual, const glm::dvec3& expected, const std::string& what) {
    EXPECT_LE(glm::length(glm::dvec3(actual) - expected), kTolerance) << what;
}

struct Cylinder {
    LoadedModel model = loadModel(cylinderFile());
    SkinnedClip skin = loadSkinnedClip(cylinderFile(), {}, model);
    SkinningScratch scratch;
    TriangleMesh deformed = model.parts.at(0).mesh;

    const TriangleMesh& at(double t) {
        boneMatricesInto(skin, t, scratch);
        skinPartInto(skin.parts[0], scratch, model.parts[0].mesh, deformed);
        return deformed;
    }
};

/// Distance from p to triangle abc (closest point by region, Ericson, Real-Time Collision Detection 5.1.5), double.
double distanceToTriangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    const glm::dvec3 ab = b - a, ac = c - a, ap = p - a;
    const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return glm::length(p - a);
    const glm::dvec3 bp = p - b;
    const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return glm::length(p - b);
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return glm::length(p - (a + d1 / (d1 - d3) * ab));
    const glm::dvec3 cp = p - c;
    const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return glm::length(p - c);
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return glm::length(p - (a + d2 / (d2 - d6) * ac));
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
        return glm::length(p - (b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b)));
    const double denominator = 1.0 / (va + vb + vc);
    return glm::length(p - (a + ab * (vb * denominator) + ac * (vc * denominator)));
}

double distanceToSurface(const glm::vec3& p, const TriangleMesh& mesh) {
    double best = 1e30;
    for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
        const auto corner = [&](int k) { return glm::dvec3(mesh.positions[mesh.indices[3 * t + std::size_t(k)]]); };
        best = std::min(best, distanceToTriangle(glm::dvec3(p), corner(0), corner(1), corner(2)));
    }
    return best;
}

} // namespace

TEST(Skinning, CompactInfluencesKeepsTheFourLargestRenormalised) {
    SkinWeights out;
    EXPECT_EQ(compactInfluences({{0, 0.05f}, {1, 0.3f}, {2, 0.1f}, {3, 0.2f}, {4, 0.15f}, {5, 0.2f}}, out), 2u);
    EXPECT_EQ(out.bones[0], 1u);
    EXPECT_NEAR(out.weights[0], 0.3f / 0.85f, 1e-6f);
    EXPECT_NEAR(out.weights[3], 0.15f / 0.85f, 1e-6f) << "the fourth largest, renormalised";
    EXPECT_EQ(out.bones[3], 4u);
    EXPECT_NEAR(out.weights[0] + out.weights[1] + out.weights[2] + out.weights[3], 1.0f, 1e-6f);

    // Weights that do not sum to 1 (files round them; some exporters never normalise) are renormalised.
    EXPECT_EQ(compactInfluences({{7, 0.2f}, {8, 0.6f}, {9, -1.0f}, {10, 0.0f}}, out), 0u);
    EXPECT_EQ(out.bones[0], 8u);
    EXPECT_NEAR(out.weights[0], 0.75f, 1e-6f);
    EXPECT_NEAR(out.weights[1], 0.25f, 1e-6f);
    EXPECT_EQ(out.weights[2], 0.0f) << "negative and zero weights are no influence";
}

TEST(Skinning, TheSampleCylinderLoadsWithItsWeights) {
    Cylinder c;
    EXPECT_EQ(c.skin.clip.name, "Bend");
    EXPECT_NEAR(c.skin.clip.durationSeconds, 1.0, 1e-9);
    ASSERT_EQ(c.skin.bones.size(), 2u);
    EXPECT_EQ(c.skin.verticesWithDroppedInfluences, 0u);
    const std::size_t upper = c.skin.clip.tree.nodes[c.skin.bones[0].node].name == "Upper" ? 0 : 1;
    EXPECT_EQ(c.skin.clip.tree.nodes[c.skin.bones[upper].node].name, "Upper");
    const TriangleMesh& rest = c.model.parts[0].mesh;
    for (std::size_t v = 0; v < rest.vertexCount(); ++v) {
        double w = 0.0;
        for (std::size_t k = 0; k < kMaxInfluences; ++k)
            if (c.skin.parts[0][v].bones[k] == upper) w += double(c.skin.parts[0][v].weights[k]);
        EXPECT_NEAR(w, upperWeight(rest.positions[v].y), 1e-6) << "vertex " << v;
    }
}

TEST(Skinning, PositionsAndNormalsFollowTheClosedFormOfTheBend) {
    Cylinder c;
    const TriangleMesh& rest = c.model.parts[0].mesh;
    for (const double t : {0.0, 0.25, 0.5, 0.8, 1.0, 2.0}) {
        const TriangleMesh& deformed = c.at(t);
        for (std::size_t v = 0; v < rest.vertexCount(); ++v) {
            const glm::dvec3 p(rest.positions[v]), n(rest.normals[v]);
            const std::string what = "t = " + std::to_string(t) + ", vertex " + std::to_string(v);
            expectNear(deformed.positions[v], skinnedClosedForm(p, t), what);
            expectNear(deformed.normals[v], skinnedNormalClosedForm(p, n, t), what + " (normal)");
        }
    }
}

TEST(Skinning, AnchoredSparsePointsStayOnTheDeformedSurface) {
    Cylinder c;
    const TriangleMesh& rest = c.model.parts[0].mesh;
    gi::SparsePointSettings settings;
    settings.pointCount = 256;
    settings.refine = false;
    const gi::SparsePointSet set = gi::sampleSparsePoints(rest, settings, "cylinder");
    ASSERT_EQ(set.anchors.size(), set.points.size());
    std::vector<gi::SparsePoint> points = set.points;
    // At rest the anchors give the sampled points back (float re-mix of a double sample: < 1e-6 m).
    gi::followSurfaceInto(rest, set.anchors, points);
    for (std::size_t i = 0; i < points.size(); ++i)
        EXPECT_LE(glm::length(points[i].position - set.points[i].position), 1e-6f) << "point " << i;

    const TriangleMesh& bent = c.at(1.0);
    gi::followSurfaceInto(bent, set.anchors, points);
    std::size_t rigid = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        // On the bent surface: the point is a float barycentric mix of its triangle's corners (< 2.2 m, three
        // products and two sums: < 5 ulp = 1.2e-6 m off the triangle); 2e-6 m, against the 0.2 m radius.
        EXPECT_LE(distanceToSurface(points[i].position, bent), 2e-6) << "point " << i;
        EXPECT_NEAR(glm::length(points[i].normal), 1.0f, 1e-5f);
        // Where the whole triangle is in one bone (y <= 0.75 or >= 1.25), the bend moves the point rigidly: the
        // closed form of the rest point.
        const std::uint32_t* corner = &rest.indices[3 * std::size_t(set.anchors[i].triangle)];
        const double w0 = upperWeight(rest.positions[corner[0]].y);
        if (w0 == upperWeight(rest.positions[corner[1]].y) && w0 == upperWeight(rest.positions[corner[2]].y) &&
            (w0 == 0.0 || w0 == 1.0)) {
            ++rigid;
            expectNear(points[i].position, skinnedClosedForm(glm::dvec3(set.points[i].position), 1.0),
                       "rigid point " + std::to_string(i));
        }
    }
    EXPECT_GT(rigid, points.size() / 2) << "most of the cylinder is outside the blend zone";
}

TEST(Skinning, BadSkinsAreNamed) {
    const LoadedModel box = loadModel(test::dataPath("meshes") / "swinging_box.gltf");
    try {
        loadSkinnedClip(test::dataPath("meshes") / "swinging_box.gltf", {}, box);
        FAIL() << "a file without a skin";
    } catch (const Error& error) {
        EXPECT_NE(error.cause().find("no mesh of the file is skinned"), std::string::npos) << error.cause();
    }
    const LoadedModel cylinder = loadModel(cylinderFile());
    try {
        loadSkinnedClip(cylinderFile(), {.clip = std::string("Wave")}, cylinder);
        FAIL() << "an unknown clip";
    } catch (const Error& error) {
        EXPECT_NE(error.cause().find("no clip named 'Wave'"), std::string::npos) << error.cause();
    }
}

TEST(Skinning, RefittedOccluderRadiiReachTheVerticesOfTheBentSurface) {
    Cylinder c;
    const TriangleMesh& rest = c.model.parts[0].mesh;
    gi::SparsePointSettings settings;
    settings.pointCount = 64; // fewer points than vertices: every point owns vertices
    settings.refine = false;
    const gi::SparsePointSet set = gi::sampleSparsePoints(rest, settings, "cylinder");
    std::vector<gi::SparsePoint> points = set.points;
    const auto worstReach = [&](const TriangleMesh& mesh) { // owner distance / radius, largest over the vertices
        double worst = 0.0;
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
            const gi::SparsePoint& owner = points[set.vertexNeighbours[v][0]];
            worst =
                std::max(worst, double(glm::length(mesh.positions[v] - owner.position)) / double(owner.occluderRadius));
        }
        return worst;
    };
    // At rest the refit gives the sampler's radii back (its own float distances: 1e-6 relative).
    gi::refitOccluderRadiiInto(rest, set.vertexNeighbours, points);
    for (std::size_t i = 0; i < points.size(); ++i)
        EXPECT_NEAR(points[i].occluderRadius, set.points[i].occluderRadius, 1e-6f * set.points[i].occluderRadius) << i;

    const TriangleMesh& bent = c.at(1.0);
    gi::followSurfaceInto(bent, set.anchors, points);
    EXPECT_GT(worstReach(bent), 1.05) << "the bend stretches the surface: kept radii stop short of some vertices";
    gi::refitOccluderRadiiInto(bent, set.vertexNeighbours, points);
    EXPECT_LE(worstReach(bent), 1.0 + 1e-6) << "refitted: every disc reaches the vertices it owns";
}
