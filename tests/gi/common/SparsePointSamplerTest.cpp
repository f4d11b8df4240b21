// Sparse scene points: farthest-point sampling on analytic meshes; vertex neighbours against brute
// force; refinement of coarse meshes. The bunny test is in SparsePointSamplerDataTest.cpp.
#include "TestMeshes.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/common/SparsePointSampler.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

namespace lightskin::test {
namespace {

using gi::SparsePointSettings;

double minPairwiseDistance(const gi::SparsePointSet& set) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < set.points.size(); ++i)
        for (std::size_t j = i + 1; j < set.points.size(); ++j)
            best = std::min(best, double(glm::length(set.points[i].position - set.points[j].position)));
    return best;
}

// Largest distance from a query point to its nearest sparse point.
double coveringRadius(const gi::SparsePointSet& set, const std::vector<glm::vec3>& queries) {
    double worst = 0.0;
    for (const glm::vec3& q : queries) {
        double nearest = std::numeric_limits<double>::infinity();
        for (const auto& p : set.points) nearest = std::min(nearest, double(glm::length(q - p.position)));
        worst = std::max(worst, nearest);
    }
    return worst;
}

TEST(SparsePointSamplerTest, PointsLieOnAPlaneAndAreEvenlySpread) {
    const TriangleMesh plane = planeGrid(1.0f, 64); // fine enough: no refinement needed at N = 256
    SparsePointSettings settings;
    settings.pointCount = 256;
    const gi::SparsePointSet set = gi::sampleSparsePoints(plane, settings);
    ASSERT_EQ(set.points.size(), 256u);
    for (const auto& p : set.points) {
        EXPECT_EQ(p.position.z, 0.0f);
        EXPECT_LE(std::abs(p.position.x), 0.5f);
        EXPECT_LE(std::abs(p.position.y), 0.5f);
        EXPECT_NEAR(glm::length(p.normal - glm::vec3(0, 0, 1)), 0.0f, 1e-6f);
    }
    const double spacing = std::sqrt(1.0 / 256); // nominal sqrt(A / N)
    const double minDistance = minPairwiseDistance(set);
    const double covering = coveringRadius(set, planeGrid(1.0f, 100).positions);
    // FPS: every point was the farthest candidate when picked, so no two points are closer than the
    // final covering radius of the candidates (up to the candidate density, M = 8N); a hexagonal
    // packing would have min distance 1.07 and covering radius 0.62 spacings.
    EXPECT_GT(minDistance, 0.6 * spacing);
    EXPECT_LT(covering, 1.0 * spacing);
    EXPECT_GT(minDistance, 0.8 * covering);
    std::printf("plane N=256: min distance %.3f, covering %.3f spacings\n", minDistance / spacing, covering / spacing);
}

TEST(SparsePointSamplerTest, IsDeterministicAndProgressive) {
    const TriangleMesh sphere = uvSphere(0.5f, 48, 96);
    SparsePointSettings settings;
    settings.pointCount = 128;
    const auto a = gi::sampleSparsePoints(sphere, settings);
    const auto b = gi::sampleSparsePoints(sphere, settings);
    settings.pointCount = 64;
    settings.candidatesPerPoint = 16; // same candidate count M = 1024 -> 4096 minimum either way
    const auto firstHalf = gi::sampleSparsePoints(sphere, settings);
    for (std::size_t i = 0; i < a.points.size(); ++i) EXPECT_EQ(a.points[i].position, b.points[i].position);
    for (std::size_t i = 0; i < firstHalf.points.size(); ++i) EXPECT_EQ(firstHalf.points[i].position, a.points[i].position) << i;
}

TEST(SparsePointSamplerTest, SpherePointsAreOnTheSurfaceWithOutwardNormals) {
    const TriangleMesh sphere = uvSphere(0.5f, 48, 96);
    SparsePointSettings settings;
    settings.pointCount = 512;
    const auto set = gi::sampleSparsePoints(sphere, settings);
    // Flat triangles sag below the sphere: cells span pi/48 in both angles, so a cell's centre lies
    // ~r (1 - cos(pi / 48 / sqrt(2))) = 0.54 mm inside.
    for (const auto& p : set.points) {
        EXPECT_LE(glm::length(p.position), 0.5f + 1e-6f);
        EXPECT_GT(glm::length(p.position), 0.5f - 6e-4f);
        EXPECT_GT(glm::dot(p.normal, glm::normalize(p.position)), 0.999f);
    }
    // Even over the sphere: each octant holds 1/8 of the points within sampling noise.
    int octant[8] = {};
    for (const auto& p : set.points) ++octant[(p.position.x > 0) + 2 * (p.position.y > 0) + 4 * (p.position.z > 0)];
    for (int count : octant) EXPECT_NEAR(count, 64, 12);
}

TEST(SparsePointSamplerTest, AnchoredPointsFollowAMovedSurface) {
    // Anchors are barycentric: any affine map of the vertices maps each point the same way. A uniform scale by 2
    // plus a shift (not a rigid move: the points must come from the moved vertices, not a stored transform) puts
    // every point at 2 p + t; the normals (vertex normals left as they are) stay the sampled ones.
    const TriangleMesh sphere = uvSphere(0.5f, 24, 48);
    SparsePointSettings settings;
    settings.pointCount = 128;
    settings.refine = false;
    const gi::SparsePointSet set = gi::sampleSparsePoints(sphere, settings);
    ASSERT_EQ(set.anchors.size(), set.points.size());
    TriangleMesh moved = sphere;
    const glm::vec3 shift(0.3f, -1.0f, 2.0f);
    for (glm::vec3& p : moved.positions) p = 2.0f * p + shift;
    std::vector<gi::SparsePoint> points = set.points;
    gi::followSurfaceInto(moved, set.anchors, points);
    for (std::size_t i = 0; i < points.size(); ++i) {
        // Float: coordinates < 2.5 m after the map, a few roundings each: < 2e-6 m.
        EXPECT_LE(glm::length(points[i].position - (2.0f * set.points[i].position + shift)), 2e-6f) << i;
        EXPECT_LE(glm::length(points[i].normal - set.points[i].normal), 1e-5f) << i;
        EXPECT_EQ(points[i].occluderRadius, set.points[i].occluderRadius) << "kept";
    }
}

TEST(SparsePointSamplerTest, VertexNeighboursAreTheEightNearestPoints) {
    const TriangleMesh sphere = uvSphere(0.5f, 24, 48);
    SparsePointSettings settings;
    settings.pointCount = 200;
    const auto set = gi::sampleSparsePoints(sphere, settings);
    ASSERT_EQ(set.vertexNeighbours.size(), sphere.vertexCount());
    for (std::size_t v = 0; v < sphere.vertexCount(); ++v) {
        std::vector<float> distances;
        for (const auto& p : set.points) distances.push_back(glm::length(sphere.positions[v] - p.position));
        std::vector<float> sorted = distances;
        std::partial_sort(sorted.begin(), sorted.begin() + gi::kVertexNeighbours, sorted.end());
        for (int j = 0; j < gi::kVertexNeighbours; ++j)
            EXPECT_NEAR(distances[set.vertexNeighbours[v][std::size_t(j)]], sorted[std::size_t(j)], 1e-6f) << v << " " << j;
    }
}

TEST(SparsePointSamplerTest, CoarseMeshesAreRefinedWithoutCracks) {
    TriangleMesh quad = planeGrid(2.0f, 1); // two triangles, edges 2 and 2.83 m
    SparsePointSettings settings;
    settings.pointCount = 256; // spacing sqrt(4 / 256) = 0.125 m
    const auto unrefined = gi::sampleSparsePoints(quad, settings);
    EXPECT_GT(unrefined.tessellationRatio, 20.0f); // 2.83 / 0.125: the mismatch is reported
    for (const auto& p : unrefined.points) EXPECT_GT(p.occluderRadius, 0.0f); // from candidates, not vertices
    const double areaBefore = gi::surfaceArea(quad);
    const auto refined = gi::prepareSparsePoints(quad, settings);
    EXPECT_LE(refined.tessellationRatio, 1.0f);
    EXPECT_LE(gi::longestEdge(quad), 0.125 + 1e-6);
    EXPECT_NEAR(gi::surfaceArea(quad), areaBefore, 1e-9);
    EXPECT_NO_THROW(quad.validate("refined quad"));
    // Orientation kept: every triangle still faces +z.
    for (std::size_t t = 0; t < quad.triangleCount(); ++t) {
        const glm::vec3 a = quad.positions[quad.indices[3 * t]], b = quad.positions[quad.indices[3 * t + 1]],
                        c = quad.positions[quad.indices[3 * t + 2]];
        ASSERT_GT(glm::cross(b - a, c - a).z, 0.0f);
    }
    // No cracks: every interior edge is shared by exactly two triangles (edge-use count 1 only on the border).
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
    for (std::size_t t = 0; t < quad.triangleCount(); ++t)
        for (std::size_t e = 0; e < 3; ++e) {
            std::uint32_t a = quad.indices[3 * t + e], b = quad.indices[3 * t + (e + 1) % 3];
            ++uses[{std::min(a, b), std::max(a, b)}];
        }
    for (const auto& [edge, count] : uses) {
        const glm::vec3 a = quad.positions[edge.first], b = quad.positions[edge.second];
        const bool border = (std::abs(a.x) == 1.0f && a.x == b.x) || (std::abs(a.y) == 1.0f && a.y == b.y);
        EXPECT_EQ(count, border ? 1 : 2);
    }
}

TEST(SparsePointSamplerTest, RefinementCapReportsTheMismatch) {
    TriangleMesh cubeMesh = cube(0.5f);
    SparsePointSettings settings;
    settings.pointCount = 16384;
    settings.maxRefinedTriangles = 200;
    const auto set = gi::prepareSparsePoints(cubeMesh, settings, "cube");
    EXPECT_LE(cubeMesh.triangleCount(), 200u);
    EXPECT_GT(set.tessellationRatio, 1.0f);
    EXPECT_EQ(set.points.size(), 16384u);
}

TEST(SparsePointSamplerTest, FewerPointsThanNeighboursRepeatTheLastIndex) {
    SparsePointSettings settings;
    settings.pointCount = 3;
    const auto set = gi::sampleSparsePoints(cube(0.5f), settings);
    for (const auto& neighbours : set.vertexNeighbours) {
        for (int j = 3; j < gi::kVertexNeighbours; ++j) EXPECT_EQ(neighbours[std::size_t(j)], neighbours[2]);
        EXPECT_LT(*std::max_element(neighbours.begin(), neighbours.end()), 3u);
    }
}

TEST(SparsePointSamplerTest, RejectsBadMeshesAndSettings) {
    SparsePointSettings settings;
    EXPECT_THROW(gi::sampleSparsePoints(TriangleMesh{}, settings), Error);
    TriangleMesh flat;
    flat.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
    flat.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
    flat.indices = {0, 1, 2};
    EXPECT_THROW(gi::sampleSparsePoints(flat, settings), Error); // no area
    settings.pointCount = 0;
    EXPECT_THROW(gi::sampleSparsePoints(cube(1.0f), settings), Error);
}

} // namespace
} // namespace lightskin::test
