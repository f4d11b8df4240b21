#include <lightskin/core/Pose.h>

#include <glm/gtc/constants.hpp>
#include <gtest/gtest.h>

namespace lightskin::test {
namespace {

TEST(PoseTest, ComposesAndInvertsRigidTransforms) {
    const Pose world_T_camera(glm::angleAxis(0.3, glm::normalize(glm::dvec3(1, 2, 3))), {0.5, -1.0, 2.0});
    const Pose camera_T_world = world_T_camera.inverse();
    const glm::dvec3 p(0.1, 0.2, 1.5);
    const glm::dvec3 back = camera_T_world.transformPoint(world_T_camera.transformPoint(p));
    EXPECT_NEAR(glm::length(back - p), 0.0, 1e-12);
    const Pose identity = world_T_camera * camera_T_world;
    EXPECT_NEAR(glm::length(identity.translation()), 0.0, 1e-12);
    EXPECT_NEAR(Pose::rotationAngleBetween(identity, Pose()), 0.0, 1e-7);
}

TEST(PoseTest, MatrixRoundTripMatchesPointTransform) {
    const Pose pose(glm::angleAxis(1.2, glm::dvec3(0, 1, 0)), {1, 2, 3});
    const Pose again = Pose::fromMatrix(pose.matrix());
    const glm::dvec3 p(-0.3, 0.7, 2.0);
    EXPECT_NEAR(glm::length(again.transformPoint(p) - pose.transformPoint(p)), 0.0, 1e-12);
    const glm::dvec4 viaMatrix = pose.matrix() * glm::dvec4(p, 1.0);
    EXPECT_NEAR(glm::length(glm::dvec3(viaMatrix) - pose.transformPoint(p)), 0.0, 1e-12);
}

TEST(PoseTest, RotationAngleIsAccurateForTinyAnglesAndHandlesDoubleCover) {
    const Pose a;
    const Pose tiny(glm::angleAxis(1e-7, glm::dvec3(0, 0, 1)), {});
    EXPECT_NEAR(Pose::rotationAngleBetween(a, tiny), 1e-7, 1e-12);
    const glm::dquat q = glm::angleAxis(0.4, glm::dvec3(1, 0, 0));
    EXPECT_NEAR(Pose::rotationAngleBetween(Pose(q, {}), Pose(-q, {})), 0.0, 1e-12);
    EXPECT_NEAR(Pose::rotationAngleBetween(a, Pose(glm::angleAxis(glm::pi<double>(), glm::dvec3(0, 1, 0)), {})),
                glm::pi<double>(), 1e-12);
}

} // namespace
} // namespace lightskin::test
