// Sparse points on real scanned geometry: the Stanford bunny (tests/data/stanford-bunny, 453
// vertices): occluder radii against a brute-force Voronoi assignment of the vertices.
#include "TestMeshes.h"
#include "TestPaths.h"

#include <lightskin/gi/common/SparsePointSampler.h>

#include <gtest/gtest.h>

#include <set>

namespace lightskin::test {
namespace {

using gi::SparsePointSettings;

TEST(SparsePointSamplerDataTest, OccluderRadiusReachesEveryVertexOfTheVoronoiRegion) {
    TriangleMesh mesh = readAsciiPly(dataPath("stanford-bunny/bun_zipper_res4.ply").string());
    ASSERT_EQ(mesh.vertexCount(), 453u);
    ASSERT_EQ(mesh.triangleCount(), 946u);
    SparsePointSettings settings;
    settings.pointCount = 64;
    const auto set = gi::prepareSparsePoints(mesh, settings, "bunny");
    std::vector<float> expected(set.points.size(), 0.0f);
    for (const glm::vec3& vertex : mesh.positions) {
        std::size_t owner = 0;
        for (std::size_t i = 1; i < set.points.size(); ++i)
            if (glm::length(vertex - set.points[i].position) < glm::length(vertex - set.points[owner].position)) owner = i;
        expected[owner] = std::max(expected[owner], glm::length(vertex - set.points[owner].position));
    }
    for (std::size_t i = 0; i < set.points.size(); ++i) {
        EXPECT_NEAR(set.points[i].occluderRadius, expected[i], 1e-6f) << i;
        EXPECT_GT(set.points[i].occluderRadius, 0.0f);
    }
    EXPECT_LE(set.tessellationRatio, 1.0f);
}

// 1024 points need a finer bunny than res4 (spacing 7 mm, edges up to ~2 cm): refinement keeps
// the surface (same area, same vertices first) and every vertex gets eight distinct neighbours.
TEST(SparsePointSamplerDataTest, CoarseBunnyIsRefinedForMorePoints) {
    const TriangleMesh original = readAsciiPly(dataPath("stanford-bunny/bun_zipper_res4.ply").string());
    TriangleMesh mesh = original;
    SparsePointSettings settings;
    settings.pointCount = 1024;
    const double spacing = gi::nominalSpacing(mesh, 1024);
    ASSERT_GT(gi::longestEdge(mesh), spacing);
    const auto set = gi::prepareSparsePoints(mesh, settings, "bunny");
    EXPECT_LE(set.tessellationRatio, 1.0f);
    EXPECT_GT(mesh.vertexCount(), original.vertexCount());
    EXPECT_NEAR(gi::surfaceArea(mesh) / gi::surfaceArea(original), 1.0, 1e-6); // float midpoints
    for (std::size_t v = 0; v < original.vertexCount(); ++v) ASSERT_EQ(mesh.positions[v], original.positions[v]);
    ASSERT_EQ(set.vertexNeighbours.size(), mesh.vertexCount());
    for (const auto& neighbours : set.vertexNeighbours) {
        std::set<std::uint32_t> distinct(neighbours.begin(), neighbours.end());
        EXPECT_EQ(distinct.size(), std::size_t(gi::kVertexNeighbours));
        EXPECT_LT(*distinct.rbegin(), 1024u);
    }
}

} // namespace
} // namespace lightskin::test
