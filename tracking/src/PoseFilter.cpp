#include <lightskin/core/Error.h>
#include <lightskin/tracking/PoseFilter.h>

#include <glm/gtc/quaternion.hpp>

#include <cmath>
#include <numbers>

namespace lightskin::tracking {

namespace {
/// Exponential-smoothing factor of a first-order low-pass with cutoff `cutoffHz` at step `dt`.
double smoothingFactor(double cutoffHz, double dt) {
    const double tau = 1.0 / (2.0 * std::numbers::pi * cutoffHz);
    return 1.0 / (1.0 + tau / dt);
}
} // namespace

Pose PoseFilter::update(const Pose& measurement, double dtSeconds) {
    LIGHTSKIN_ASSERT(dtSeconds > 0.0 && std::isfinite(dtSeconds), "dtSeconds must be positive");
    if (!settings_.enabled || !initialised_) {
        filtered_ = measurement;
        velocity_ = glm::dvec3(0.0);
        angularSpeed_ = 0.0;
        initialised_ = true;
        return filtered_;
    }
    const double derivativeAlpha = smoothingFactor(settings_.derivativeCutoffHz, dtSeconds);

    // Translation.
    const glm::dvec3 rawVelocity = (measurement.translation() - filtered_.translation()) / dtSeconds;
    velocity_ += derivativeAlpha * (rawVelocity - velocity_);
    const double translationCutoff = settings_.minCutoffHz + settings_.betaTranslation * glm::length(velocity_);
    const double translationAlpha = smoothingFactor(translationCutoff, dtSeconds);
    const glm::dvec3 translation =
        filtered_.translation() + translationAlpha * (measurement.translation() - filtered_.translation());

    // Rotation: geodesic step towards the measurement.
    glm::dquat target = measurement.rotation();
    if (glm::dot(target, filtered_.rotation()) < 0.0) target = -target; // shortest way round
    const double angle = Pose::rotationAngleBetween(filtered_, measurement);
    angularSpeed_ += derivativeAlpha * (angle / dtSeconds - angularSpeed_);
    const double rotationCutoff = settings_.minCutoffHz + settings_.betaRotation * angularSpeed_;
    const double rotationAlpha = smoothingFactor(rotationCutoff, dtSeconds);
    const glm::dquat rotation = glm::slerp(filtered_.rotation(), target, rotationAlpha);

    filtered_ = Pose(rotation, translation);
    return filtered_;
}

} // namespace lightskin::tracking
