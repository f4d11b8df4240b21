#include <lightskin/render/CameraProjection.h>

#include <gtest/gtest.h>

#include <random>

using namespace lightskin;

// clipFromCamera + perspective divide + GL viewport + image flip must land on the same pixel as
// CameraIntrinsics::project (the OpenCV model) for any point in front of the camera.
TEST(CameraProjection, AgreesWithIntrinsicsProject) {
    const CameraIntrinsics cameras[] = {CameraIntrinsics::kinectV1Default(), CameraIntrinsics::tumFreiburg3(),
                                        {640, 480, 481.2, -480.0, 319.5, 239.5, {}} /* ICL-NUIM: fy < 0 */,
                                        {80, 60, 70.0, 71.0, 37.3, 31.8, {}}};
    std::mt19937 random(7);
    std::uniform_real_distribution<double> xy(-1.5, 1.5), z(0.3, 6.0);
    for (const CameraIntrinsics& k : cameras) {
        const glm::dmat4 clip_T_camera = render::clipFromCamera(k, 0.05, 20.0);
        for (int i = 0; i < 200; ++i) {
            const glm::dvec3 p(xy(random), xy(random), z(random));
            const glm::dvec2 expected = k.project(p);
            const glm::dvec2 actual = render::pixelFromClip(clip_T_camera * glm::dvec4(p, 1.0), k.width, k.height);
            ASSERT_NEAR(actual.x, expected.x, 1e-6) << k.describe();
            ASSERT_NEAR(actual.y, expected.y, 1e-6) << k.describe();
        }
    }
}

TEST(CameraProjection, NearAndFarMapToTheDepthRange) {
    const CameraIntrinsics k = CameraIntrinsics::kinectV1Default();
    const glm::dmat4 m = render::clipFromCamera(k, 0.1, 10.0);
    const glm::dvec4 nearPoint = m * glm::dvec4(0.0, 0.0, 0.1, 1.0), farPoint = m * glm::dvec4(0.3, -0.2, 10.0, 1.0);
    EXPECT_NEAR(nearPoint.z / nearPoint.w, -1.0, 1e-12);
    EXPECT_NEAR(farPoint.z / farPoint.w, 1.0, 1e-12);
}

TEST(CameraProjection, WorldPointsGoThroughTheInversePose) {
    const CameraIntrinsics k = CameraIntrinsics::kinectV1Default();
    const Pose world_T_camera(glm::angleAxis(0.4, glm::normalize(glm::dvec3(0.2, 1.0, -0.3))), {0.5, -0.2, 1.1});
    const glm::dvec3 pCamera(0.1, -0.15, 1.7);
    const glm::dvec3 pWorld = world_T_camera.transformPoint(pCamera);
    const glm::dvec2 actual = render::pixelFromClip(render::clipFromWorld(k, world_T_camera, 0.05, 20.0) * glm::dvec4(pWorld, 1.0), k.width, k.height);
    EXPECT_NEAR(actual.x, k.project(pCamera).x, 1e-6);
    EXPECT_NEAR(actual.y, k.project(pCamera).y, 1e-6);
}
