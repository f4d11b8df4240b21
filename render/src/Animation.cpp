#include <lightskin/core/Error.h>
#include <lightskin/render/Animation.h>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>

namespace lightskin::render {

namespace {

/// The key pair around `t` and the blend weight between them, after looping or clamping.
struct KeySpan {
    std::size_t first = 0, second = 0; ///< equal when the time holds one key
    float weight = 0.0f;               ///< 0 = first, 1 = second
};

template <class Key>
KeySpan keySpanAt(const std::vector<Key>& keys, bool loop, double t) {
    LIGHTSKIN_ASSERT(!keys.empty(), "an animation without keys");
    const double start = keys.front().timeSeconds, end = keys.back().timeSeconds;
    const std::size_t last = keys.size() - 1;
    if (!std::isfinite(t) || t <= start || last == 0) return {0, 0, 0.0f};
    if (t >= end) {
        if (!loop) return {last, last, 0.0f};
        t = start + std::fmod(t - start, end - start); // in [start, end)
    }
    std::size_t i = 0; // keys are few (a handful to hundreds): a linear search
    while (i + 1 < last && keys[i + 1].timeSeconds <= t) ++i;
    const double span = keys[i + 1].timeSeconds - keys[i].timeSeconds;
    return {i, i + 1, float(std::clamp((t - keys[i].timeSeconds) / span, 0.0, 1.0))};
}

/// The unit direction a fraction `w` of the way along the shorter great arc from `a` to `b` (both unit).
glm::vec3 slerpDirection(const glm::vec3& a, const glm::vec3& b, float w) {
    const float cosine = std::clamp(glm::dot(a, b), -1.0f, 1.0f);
    const float angle = std::acos(cosine);
    if (angle < 1e-6f) return a;
    glm::vec3 axis = glm::cross(a, b);
    if (glm::length(axis) < 1e-6f) { // opposite: any axis perpendicular to a
        axis = glm::cross(a, std::abs(a.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0));
    }
    return glm::normalize(glm::angleAxis(w * angle, glm::normalize(axis)) * a);
}

} // namespace

glm::quat rotationFromEulerDegrees(const glm::vec3& rotationDegrees) {
    // composeTransform's order: R = Rz * Ry * Rx
    return glm::angleAxis(glm::radians(rotationDegrees.z), glm::vec3(0, 0, 1)) *
           glm::angleAxis(glm::radians(rotationDegrees.y), glm::vec3(0, 1, 0)) *
           glm::angleAxis(glm::radians(rotationDegrees.x), glm::vec3(1, 0, 0));
}

TransformKey sampleTransformKey(const TransformAnimation& animation, double timeSeconds) {
    const KeySpan span = keySpanAt(animation.keys, animation.loop, timeSeconds);
    const TransformKey& a = animation.keys[span.first];
    const TransformKey& b = animation.keys[span.second];
    const float w = span.weight;
    TransformKey out;
    out.timeSeconds = timeSeconds;
    out.translation = glm::mix(a.translation, b.translation, w);
    // glm::slerp takes the shorter arc (it flips b when the dot product is negative).
    out.rotation = glm::normalize(glm::slerp(a.rotation, b.rotation, w));
    out.scale = a.scale + (b.scale - a.scale) * w;
    return out;
}

glm::mat4 sampleTransform(const TransformAnimation& animation, double timeSeconds) {
    const TransformKey key = sampleTransformKey(animation, timeSeconds);
    return glm::translate(glm::mat4(1.0f), key.translation) * glm::mat4_cast(key.rotation) *
           glm::scale(glm::mat4(1.0f), glm::vec3(key.scale));
}

LightKey sampleLight(const LightAnimation& animation, double timeSeconds) {
    const KeySpan span = keySpanAt(animation.keys, animation.loop, timeSeconds);
    const LightKey& a = animation.keys[span.first];
    const LightKey& b = animation.keys[span.second];
    const float w = span.weight;
    LightKey out;
    out.timeSeconds = timeSeconds;
    out.position = glm::mix(a.position, b.position, w);
    out.direction = slerpDirection(a.direction, b.direction, w);
    out.power = glm::mix(a.power, b.power, w);
    return out;
}

} // namespace lightskin::render
