// The checks a host's change to the content passes (mr/SceneContent.h): every placement a scene's transform can
// give passes (rotations, uniform scales, mirrorings, float rounding of composed rotations); shear, stretch,
// singular, projective and non-finite matrices do not, and the error names the object and the cause. The
// animation clock starts at the first frame and falls back to frame indices without timestamps.
#include "TestPaths.h"

#include <lightskin/core/Error.h>
#include <lightskin/mr/SceneContent.h>

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <limits>

using namespace lightskin;

namespace {

std::string causeOf(const glm::mat4& m) {
    try {
        mr::checkPlacement(m, "scene.json", "object 4");
    } catch (const Error& error) {
        EXPECT_EQ(error.source(), "scene.json");
        return error.cause();
    }
    return "(no error)";
}

} // namespace

TEST(SceneContent, PlacementsAScenesTransformGivesPass) {
    for (const glm::vec3 rotation : {glm::vec3(0), glm::vec3(90, 0, 0), glm::vec3(13.7f, -122.1f, 301.5f)})
        for (const float scale : {1e-3f, 0.12f, 1.0f, 250.0f})
            EXPECT_EQ(causeOf(render::composeTransform({1.5f, -2.0f, 0.7f}, rotation, scale)), "(no error)")
                << "scale " << scale;
    // A mirroring (negative determinant): the renderer sets the front face for it.
    EXPECT_EQ(causeOf(glm::scale(glm::mat4(1.0f), glm::vec3(-0.5f, 0.5f, 0.5f))), "(no error)");
}

TEST(SceneContent, ShearStretchSingularAndNonFiniteAreRefusedByName) {
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    glm::mat4 shear(1.0f), stretch(1.0f), projective(1.0f), zero(1.0f), notANumber(1.0f), infinite(1.0f);
    shear[1][0] = 0.01f;     // 1 % shear: 10x the tolerance
    stretch[0][0] = 1.01f;   // 1 % stretch along x
    projective[2][3] = 0.1f; // a last row other than 0 0 0 1
    zero[1][1] = 0.0f;
    notANumber[3][0] = nan;
    infinite[0][0] = inf;
    const std::pair<glm::mat4, std::string> cases[] = {
        {shear, "object 4: the transform must be a rotation times one uniform scale"},
        {stretch, "object 4: the transform must be a rotation times one uniform scale"},
        {projective, "object 4: the transform's last row must be 0 0 0 1"},
        {zero, "object 4: the transform is singular"},
        {notANumber, "object 4: the transform has a non-finite element"},
        {infinite, "object 4: the transform has a non-finite element"},
    };
    for (const auto& [m, expected] : cases) EXPECT_EQ(causeOf(m).rfind(expected, 0), 0u) << causeOf(m);
}

TEST(SceneContent, LightsAndMaterialsAreCheckedByValue) {
    render::SceneLight spot;
    spot.type = render::LightType::Spot;
    spot.direction = glm::vec3(0.0f);
    EXPECT_THROW(mr::checkLightValues(spot, "s", "light 0"), Error) << "a spot without a direction";
    render::SceneLight point;
    point.direction = glm::vec3(0.0f); // ignored on a point light
    EXPECT_NO_THROW(mr::checkLightValues(point, "s", "light 0"));
    point.power = glm::vec3(1.0f, -0.001f, 1.0f);
    EXPECT_THROW(mr::checkLightValues(point, "s", "light 0"), Error);
    render::MaterialOverride m;
    m.specularExponent = 0.5f;
    EXPECT_THROW(mr::checkMaterial(m, "s", "object 0"), Error);
    m.specularExponent = 1.0f;
    m.specularAlbedo = glm::vec3(0.0f, 1.0f, 0.5f);
    EXPECT_NO_THROW(mr::checkMaterial(m, "s", "object 0"));
}

TEST(SceneContent, TheAnimationClockStartsAtTheFirstFrame) {
    mr::AnimationClock timed;
    RgbdFrame frame;
    frame.index = 7;
    frame.colourTimestampSeconds = 1000.25;
    EXPECT_EQ(timed.timeOf(frame), 0.0);
    frame.colourTimestampSeconds = 1001.75;
    EXPECT_EQ(timed.timeOf(frame), 1.5);
    mr::AnimationClock untimed; // without timestamps: 30 frames per second from the first index
    frame.colourTimestampSeconds = std::numeric_limits<double>::quiet_NaN();
    EXPECT_EQ(untimed.timeOf(frame), 0.0);
    frame.index = 22;
    EXPECT_DOUBLE_EQ(untimed.timeOf(frame), 0.5);
}

TEST(SceneContent, GltfClipsPlaceObjectsWhereTheirClipSaysAndPassThePlacementCheck) {
    // swinging_box.gltf's clip "Swing" turns and lifts the box (tests/render/GltfAnimationTest.cpp has its closed
    // form); every pose along it, inside a rotated and scaled object transform, is a placement a host could give.
    render::Scene scene = render::parseScene(
        R"({"version": 1, "objects": [{"mesh": "swinging_box.gltf", "animation": {"source": "gltf", "loop": true},
             "transform": {"rotationDegrees": [10, 20, 30], "scale": 0.3}}]})",
        test::dataPath("meshes"), "scene.json");
    for (double t = 0.0; t < 4.5; t += 0.1) {
        mr::sampleAnimations(scene, t);
        EXPECT_EQ(scene.objects[0].world_T_model, render::placementAt(scene.objects[0], t));
        mr::checkPlacement(scene.objects[0].world_T_model, "scene.json", "object 0");
    }
}
