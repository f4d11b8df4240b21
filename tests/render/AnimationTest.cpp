// Keyframe animation (render/Animation.h) against closed forms: placements at the keys equal the scene's
// transform of the same values (composeTransform, a separate matrix composition), between keys translation and
// scale are linear and the rotation turns at constant angular speed along the shorter arc; times before, after
// and beyond a loop hold or wrap as documented.
#include <lightskin/render/Animation.h>
#include <lightskin/render/Scene.h>

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

using namespace lightskin::render;

namespace {

TransformKey key(double t, glm::vec3 translation, glm::vec3 rotationDegrees, float scale) {
    return {t, translation, rotationFromEulerDegrees(rotationDegrees), scale};
}

/// Float rotations composed two ways agree to a few ulps of the largest element (|m| <= 3 here).
void expectNear(const glm::mat4& a, const glm::mat4& b, float tolerance = 2e-6f) {
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) EXPECT_NEAR(a[c][r], b[c][r], tolerance) << "column " << c << " row " << r;
}

/// A 2-key animation: at t = 1 s (0, 0, 0), no rotation, scale 1; at t = 3 s (2, -4, 6), 90 degrees about z, scale 3.
TransformAnimation twoKeys(bool loop) {
    return {{key(1.0, {0, 0, 0}, {0, 0, 0}, 1.0f), key(3.0, {2, -4, 6}, {0, 0, 90}, 3.0f)}, loop};
}

} // namespace

TEST(Animation, AtItsKeysAnObjectIsPlacedAsTheSceneTransformPlacesIt) {
    const glm::vec3 rotation(30.0f, -50.0f, 120.0f);
    const TransformAnimation a{{key(0.0, {1, 2, 3}, rotation, 0.5f), key(2.0, {-1, 0, 4}, {10, 20, 30}, 2.0f)}, false};
    expectNear(sampleTransform(a, 0.0), composeTransform({1, 2, 3}, rotation, 0.5f));
    expectNear(sampleTransform(a, 2.0), composeTransform({-1, 0, 4}, {10, 20, 30}, 2.0f));
}

TEST(Animation, BetweenKeysTranslationAndScaleAreLinearAndTheRotationTurnsUniformly) {
    const TransformAnimation a = twoKeys(false);
    for (const double t : {1.5, 2.0, 2.5}) {
        const double w = (t - 1.0) / 2.0;
        const float angle = float(w * std::numbers::pi / 2.0); // constant angular speed about z
        const float scale = float(1.0 + 2.0 * w);
        const glm::mat4 expected =
            glm::translate(glm::mat4(1.0f), glm::vec3(float(2 * w), float(-4 * w), float(6 * w))) *
            glm::rotate(glm::mat4(1.0f), angle, glm::vec3(0, 0, 1)) * glm::scale(glm::mat4(1.0f), glm::vec3(scale));
        SCOPED_TRACE("t = " + std::to_string(t));
        expectNear(sampleTransform(a, t), expected, 5e-6f);
    }
}

TEST(Animation, RotationTakesTheShorterArc) {
    // 170 and -170 degrees about z are 20 degrees apart through 180, not 340 through 0.
    const TransformAnimation a{{key(0.0, {}, {0, 0, 170}, 1.0f), key(1.0, {}, {0, 0, -170}, 1.0f)}, false};
    expectNear(sampleTransform(a, 0.5), glm::rotate(glm::mat4(1.0f), float(std::numbers::pi), glm::vec3(0, 0, 1)));
    expectNear(sampleTransform(a, 0.25), composeTransform({}, {0, 0, 175}, 1.0f));
}

TEST(Animation, HoldsTheEndKeysWithoutLoopAndWrapsWithIt) {
    const TransformAnimation clamped = twoKeys(false), looped = twoKeys(true);
    const glm::mat4 first = sampleTransform(clamped, 1.0), last = sampleTransform(clamped, 3.0);
    EXPECT_EQ(sampleTransform(clamped, 0.0), first) << "before the first key";
    EXPECT_EQ(sampleTransform(clamped, 7.5), last) << "after the last key";
    EXPECT_EQ(sampleTransform(clamped, std::numeric_limits<double>::quiet_NaN()), first);
    EXPECT_EQ(sampleTransform(looped, 0.0), first) << "a loop starts at its first key";
    // period 2 s from t = 1 s: 4.5 s is 1.5 s into the second turn, like 2.5 s in the first.
    expectNear(sampleTransform(looped, 4.5), sampleTransform(clamped, 2.5), 1e-5f);
    expectNear(sampleTransform(looped, 3.0), first, 1e-6f); // the end of one turn is the start of the next
}

TEST(Animation, LightsMoveLinearlyAndTurnAlongTheShorterArc) {
    const LightAnimation a{
        {{0.0, {0, 0, 2}, {1, 0, 0}, glm::vec3(60.0f)}, {4.0, {4, 0, 2}, {0, 1, 0}, glm::vec3(0.0f)}}, false};
    const LightKey at1 = sampleLight(a, 1.0);
    EXPECT_NEAR(at1.position.x, 1.0f, 1e-6f);
    EXPECT_NEAR(at1.power.g, 45.0f, 1e-5f);
    // a quarter of the 90 degree turn in the xy plane: 22.5 degrees from +x
    const float angle = float(std::numbers::pi / 8.0);
    EXPECT_NEAR(at1.direction.x, std::cos(angle), 1e-6f);
    EXPECT_NEAR(at1.direction.y, std::sin(angle), 1e-6f);
    EXPECT_NEAR(at1.direction.z, 0.0f, 1e-6f);
    // Opposite directions: half way is perpendicular to both, still unit.
    const LightAnimation opposite{{{0.0, {}, {0, 0, 1}, {}}, {1.0, {}, {0, 0, -1}, {}}}, false};
    const glm::vec3 d = sampleLight(opposite, 0.5).direction;
    EXPECT_NEAR(glm::length(d), 1.0f, 1e-6f);
    EXPECT_NEAR(d.z, 0.0f, 1e-6f);
}
