// gi::TriangleRayScene (the Embree scene shared by the differential, the ground truth and synth) against
// closed forms: a unit right triangle in the plane z = 1, moved by world_T_model, hit by rays whose
// parameter, barycentrics and triangle are known exactly; meshes without triangles are skipped without
// shifting the mesh indices of the others; segment tests stop at tFar; segmentOccluded cuts epsilon metres
// off both ends.
#include <lightskin/gi/common/TriangleRayScene.h>

#include <glm/ext/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <limits>
#include <vector>

namespace {

using lightskin::TriangleMesh;
using lightskin::gi::RayMesh;
using lightskin::gi::TriangleRayScene;

/// Two triangles: (0,0,0) (1,0,0) (0,1,0) and its mirror (1,1,0) (0,1,0) (1,0,0): the unit square, z = 0.
TriangleMesh unitSquare() {
    TriangleMesh m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
    m.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
    m.indices = {0, 1, 2, 3, 2, 1};
    return m;
}

} // namespace

TEST(TriangleRayScene, ClosestHitNamesMeshTriangleBarycentricsAndDistance) {
    const double kTEps = 4.0 * double(std::numeric_limits<float>::epsilon());
    const TriangleMesh empty; // no triangles: skipped, yet the square keeps index 1
    const TriangleMesh square = unitSquare();
    // The square lifted to z = 1 and a second copy at z = 3 (behind it along +z).
    const std::vector<RayMesh> meshes = {{&empty, glm::dmat4(1.0)},
                                         {&square, glm::translate(glm::dmat4(1.0), glm::dvec3(0, 0, 1))},
                                         {&square, glm::translate(glm::dmat4(1.0), glm::dvec3(0, 0, 3))}};
    const TriangleRayScene scene = TriangleRayScene::create(meshes, "test");

    // Up the z axis through (0.25, 0.5): the first triangle, vertex 1 weight u = 0.25, vertex 2 v = 0.5.
    // Every value is a binary fraction, exact in float, yet Embree computes t in float through an approximate
    // reciprocal refined by one Newton step, and its SSE, AVX2 and AVX-512 kernels round that differently
    // (0.99999994 = 1 - 1 ulp on an AVX2 CPU): distances within a few ulp, kTEps.
    const auto hit = scene.intersect({0.25, 0.5, 0.0}, {0, 0, 1}, 0.0, std::numeric_limits<double>::infinity());
    ASSERT_TRUE(hit.has_value());
    EXPECT_EQ(hit->mesh, 1u);
    EXPECT_EQ(hit->triangle, 0u);
    EXPECT_NEAR(hit->t, 1.0, kTEps);
    EXPECT_NEAR(hit->u, 0.25, 1e-6); // Embree's float barycentrics: a few ulp
    EXPECT_NEAR(hit->v, 0.5, 1e-6);
    // Through (0.75, 0.75), in the second triangle, direction of length 2: t = distance / 2.
    const auto second = scene.intersect({0.75, 0.75, 0.0}, {0, 0, 2}, 0.0, 10.0);
    ASSERT_TRUE(second.has_value());
    EXPECT_EQ(second->mesh, 1u);
    EXPECT_EQ(second->triangle, 1u);
    EXPECT_NEAR(second->t, 0.5, kTEps * 0.5);
    // Starting past the first square: the copy behind it (mesh 2) at distance 1.
    const auto behind = scene.intersect({0.25, 0.5, 2.0}, {0, 0, 1}, 0.0, 10.0);
    ASSERT_TRUE(behind.has_value());
    EXPECT_EQ(behind->mesh, 2u);
    EXPECT_NEAR(behind->t, 1.0, kTEps);
    // Beside the squares: no hit.
    EXPECT_FALSE(scene.intersect({1.5, 0.5, 0.0}, {0, 0, 1}, 0.0, 10.0).has_value());
}

TEST(TriangleRayScene, SegmentsAreOccludedOnlyWithinTheirParameterRange) {
    const TriangleMesh square = unitSquare();
    const std::vector<RayMesh> meshes = {{&square, glm::translate(glm::dmat4(1.0), glm::dvec3(0, 0, 1))}};
    const TriangleRayScene scene = TriangleRayScene::create(meshes, "test");
    // The segment (0.5, 0.5, 0) -> (0.5, 0.5, 2) crosses the square at its middle (t = 0.5).
    const glm::dvec3 from(0.5, 0.5, 0.0), to(0.5, 0.5, 2.0);
    EXPECT_TRUE(scene.occluded(from, to - from, 1e-4, 1.0 - 1e-4));
    EXPECT_FALSE(scene.occluded(from, to - from, 1e-4, 0.49));          // stops short of the square
    EXPECT_FALSE(scene.occluded(from, to - from, 0.51, 1.0));           // starts past it
    EXPECT_FALSE(scene.occluded({2.0, 2.0, 0.0}, {0, 0, 2}, 0.0, 1.0)); // beside it
}

TEST(TriangleRayScene, SegmentOcclusionIgnoresTheEndSurfacesWithinEpsilonMetres) {
    const TriangleMesh square = unitSquare();
    const std::vector<RayMesh> meshes = {{&square, glm::translate(glm::dmat4(1.0), glm::dvec3(0, 0, 1))}};
    const TriangleRayScene scene = TriangleRayScene::create(meshes, "test");
    // Through the square (z = 1) from z = 0 to z = 3: blocked whatever the length (epsilon is metres).
    EXPECT_TRUE(scene.segmentOccluded({0.5, 0.5, 0.0}, {0.5, 0.5, 3.0}, 1e-3));
    // Ending on the square (0.5 mm short of it after the epsilon cut): the end point's own surface.
    EXPECT_FALSE(scene.segmentOccluded({0.5, 0.5, 0.0}, {0.5, 0.5, 1.0}, 1e-3));
    // Starting 0.5 mm above it and leaving: the epsilon (1 mm) skips it; a 0.1 mm epsilon does not.
    EXPECT_FALSE(scene.segmentOccluded({0.5, 0.5, 1.0005}, {0.5, 0.5, 0.5}, 1e-3));
    EXPECT_TRUE(scene.segmentOccluded({0.5, 0.5, 1.0005}, {0.5, 0.5, 0.5}, 1e-4));
    // Not longer than 2 epsilon: nothing to test.
    EXPECT_FALSE(scene.segmentOccluded({0.5, 0.5, 0.9995}, {0.5, 0.5, 1.0005}, 1e-3));
}

