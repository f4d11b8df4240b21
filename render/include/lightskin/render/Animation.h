#pragma once
// Keyframed animation of the scene's objects and lights (docs/SCENE_FORMAT.md, "animation").
//
// Time: seconds from the first frame the pipeline renders (the recording's first frame, or a host
// session's first submitted frame). Keys are sorted by time, strictly increasing. Before the first key
// an animation holds the first key; after the last it holds the last one, or with `loop` starts over at
// the first key (period = last key's time - first key's time).
//
// Objects: world_T_model = translate(t) * rotate(q) * uniform scale(s), the placement a scene
// "transform" gives (composeTransform); translation and scale are interpolated linearly, the rotation
// spherically (quaternion slerp, the shorter arc). Lights: position and power linearly, a spot light's
// direction spherically (the rotation of the shorter arc between two keys' directions).

#include <glm/gtc/quaternion.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include <vector>

namespace lightskin::render {

struct TransformKey {
    double timeSeconds = 0.0;
    glm::vec3 translation{0.0f};       ///< metres, world
    glm::quat rotation{1.0f, 0, 0, 0}; ///< unit, world_R_model
    float scale = 1.0f;                ///< uniform, > 0
};

struct TransformAnimation {
    std::vector<TransformKey> keys; ///< at least one; times strictly increasing
    bool loop = false;
};

struct LightKey {
    double timeSeconds = 0.0;
    glm::vec3 position{0.0f};               ///< metres, world
    glm::vec3 direction{0.0f, 0.0f, -1.0f}; ///< unit, world (spot lights; ignored for points)
    glm::vec3 power{0.0f};                  ///< watts, linear RGB, >= 0
};

struct LightAnimation {
    std::vector<LightKey> keys; ///< at least one; times strictly increasing
    bool loop = false;
};

/// The placement at `timeSeconds` (see the header comment). `animation.keys` must not be empty.
glm::mat4 sampleTransform(const TransformAnimation& animation, double timeSeconds);
/// The same as its parts: the interpolated translation, rotation and scale (timeSeconds = the argument).
TransformKey sampleTransformKey(const TransformAnimation& animation, double timeSeconds);
/// The light's position, direction and power at `timeSeconds`. `animation.keys` must not be empty.
LightKey sampleLight(const LightAnimation& animation, double timeSeconds);

/// The rotation of composeTransform's Euler angles (degrees; about x, then y, then z).
glm::quat rotationFromEulerDegrees(const glm::vec3& rotationDegrees);

} // namespace lightskin::render
