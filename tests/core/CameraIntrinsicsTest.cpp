#include <lightskin/core/CameraIntrinsics.h>

#include <glm/geometric.hpp>

#include <gtest/gtest.h>

namespace lightskin::test {
namespace {

TEST(CameraIntrinsicsTest, ProjectInvertsBackProject) {
    const CameraIntrinsics k = CameraIntrinsics::tumFreiburg3();
    const glm::dvec3 p = k.backProject(100.25, 400.5, 2.5);
    EXPECT_DOUBLE_EQ(p.z, 2.5);
    const glm::dvec2 uv = k.project(p);
    EXPECT_NEAR(uv.x, 100.25, 1e-12);
    EXPECT_NEAR(uv.y, 400.5, 1e-12);
}

TEST(CameraIntrinsicsTest, ScalingKeepsPixelCentresOnTheSameRays) {
    const CameraIntrinsics full = CameraIntrinsics::kinectV1Default();
    const CameraIntrinsics half = full.scaledTo(320, 240);
    // The centre of half-resolution pixel (10,20) covers full pixels 20..21 x 40..41: centre 20.5, 40.5.
    const glm::dvec3 rayHalf = half.backProject(10, 20, 1.0);
    const glm::dvec3 rayFull = full.backProject(20.5, 40.5, 1.0);
    EXPECT_NEAR(glm::length(rayHalf - rayFull), 0.0, 1e-12);
}

TEST(CameraIntrinsicsTest, ValidityAndNegativeFy) {
    EXPECT_FALSE(CameraIntrinsics{}.isValid());
    CameraIntrinsics icl{640, 480, 481.2, -480.0, 319.5, 239.5, {}};
    EXPECT_TRUE(icl.isValid());
    EXPECT_FALSE(icl.hasDistortion());
    EXPECT_TRUE(CameraIntrinsics::tumFreiburg1().hasDistortion());
    EXPECT_LT(icl.backProject(319.5, 0.0, 1.0).y, 0.0 + 1.0); // finite, no division trouble
}

} // namespace
} // namespace lightskin::test
