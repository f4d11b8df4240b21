#include "Random.h"

#include <lightskin/core/Error.h>
#include <lightskin/synth/SceneDescription.h>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>

#include <cmath>
#include <numbers>

namespace lightskin::synth {

namespace {

constexpr double degrees = std::numbers::pi / 180.0;

double ease(double t, bool smooth) { return smooth ? t * t * (3.0 - 2.0 * t) : t; }

// Camera looking along `forward` (world), no roll, world z up.
Pose lookAlong(const glm::dvec3& position, const glm::dvec3& forward) {
    const glm::dvec3 z = glm::normalize(forward);
    glm::dvec3 right = glm::cross(z, glm::dvec3(0.0, 0.0, 1.0));
    // Looking straight up or down: any right vector will do; take world x.
    if (glm::length(right) < 1e-9) right = glm::dvec3(1.0, 0.0, 0.0);
    const glm::dvec3 x = glm::normalize(right);
    const glm::dvec3 y = glm::cross(z, x);
    return Pose(glm::quat_cast(glm::dmat3(x, y, z)), position);
}

Pose segmentPose(const PathSegment& segment, double t) {
    const double s = ease(t, segment.smooth);
    switch (segment.type) {
    case PathSegmentType::Orbit: {
        const double azimuth = (segment.startDegrees + s * (segment.endDegrees - segment.startDegrees)) * degrees;
        const glm::dvec3 position{segment.center.x + segment.radius * std::cos(azimuth),
                                  segment.center.y + segment.radius * std::sin(azimuth), segment.height};
        return lookAt(position, segment.fromTarget);
    }
    case PathSegmentType::Linear:
        return lookAt(glm::mix(segment.fromPosition, segment.toPosition, s), glm::mix(segment.fromTarget, segment.toTarget, s));
    case PathSegmentType::Pan: {
        const double yaw = (segment.startDegrees + s * (segment.endDegrees - segment.startDegrees)) * degrees;
        const double pitch = segment.pitchDegrees * degrees;
        return lookAlong(segment.fromPosition,
                         {std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch)});
    }
    case PathSegmentType::Hold:
        return lookAt(segment.fromPosition, segment.fromTarget);
    }
    return {};
}

// Sum of three sinusoids of random frequency in [0.4, 3] Hz and random phase, amplitudes chosen
// so that the sum has standard deviation 1 over a long time (each term contributes a^2/2).
double shakeSignal(std::uint64_t seed, std::uint64_t axis, double seconds) {
    constexpr int terms = 3;
    const double amplitude = std::sqrt(2.0 / terms);
    double sum = 0.0;
    for (std::uint64_t k = 0; k < terms; ++k) {
        const double frequency = 0.4 + 2.6 * uniform01(seed, axis, k, 0);
        const double phase = 2.0 * std::numbers::pi * uniform01(seed, axis, k, 1);
        sum += amplitude * std::sin(2.0 * std::numbers::pi * frequency * seconds + phase);
    }
    return sum;
}

} // namespace

Pose lookAt(const glm::dvec3& position, const glm::dvec3& target) {
    LIGHTSKIN_ASSERT(glm::length(target - position) > 1e-9, "lightskin::synth::lookAt(): target equals position");
    return lookAlong(position, target - position);
}

Pose cameraPoseAt(const CameraPathDescription& path, int frameIndex) {
    LIGHTSKIN_ASSERT(frameIndex >= 0 && frameIndex < path.frameCount(),
                     "lightskin::synth::cameraPoseAt(): frame index outside the path");
    int first = 0;
    Pose world_T_camera;
    for (const PathSegment& segment : path.segments) {
        if (frameIndex < first + segment.frames) {
            world_T_camera = segmentPose(segment, double(frameIndex - first) / double(segment.frames));
            break;
        }
        first += segment.frames;
    }
    const ShakeDescription& shake = path.shake;
    if (shake.translationStdMetres <= 0.0 && shake.rotationStdDegrees <= 0.0) return world_T_camera;
    const double seconds = double(frameIndex) / path.fps;
    const glm::dvec3 translation = shake.translationStdMetres *
        glm::dvec3(shakeSignal(shake.seed, 0, seconds), shakeSignal(shake.seed, 1, seconds), shakeSignal(shake.seed, 2, seconds));
    const glm::dvec3 rotationVector = shake.rotationStdDegrees * degrees *
        glm::dvec3(shakeSignal(shake.seed, 3, seconds), shakeSignal(shake.seed, 4, seconds), shakeSignal(shake.seed, 5, seconds));
    const double angle = glm::length(rotationVector);
    const glm::dquat shakeRotation =
        angle > 0.0 ? glm::angleAxis(angle, rotationVector / angle) : glm::dquat(1.0, 0.0, 0.0, 0.0);
    // Rotation about the camera's own axes (right-multiplied), translation in the world.
    return Pose(world_T_camera.rotation() * shakeRotation, world_T_camera.translation() + translation);
}

} // namespace lightskin::synth
