// The One-Euro SE(3) filter: it must remove jitter at rest and not lag real motion. Both are
// measured here on synthetic pose sequences with known truth (30 fps, measurement noise like a
// 100-150 px tag: 1 mm and 0.1 degree standard deviation).
#include <lightskin/tracking/PoseFilter.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <cstdio>
#include <numbers>

namespace lightskin::tracking {
namespace {

constexpr double dt = 1.0 / 30.0;

Pose noisy(const Pose& truth, cv::RNG& rng, double positionSigma, double angleSigmaRadians) {
    const glm::dvec3 axis = glm::normalize(glm::dvec3(rng.gaussian(1.0), rng.gaussian(1.0), rng.gaussian(1.0)));
    const glm::dquat wobble = glm::angleAxis(rng.gaussian(angleSigmaRadians), axis);
    return Pose(wobble * truth.rotation(),
                truth.translation() +
                    glm::dvec3(rng.gaussian(positionSigma), rng.gaussian(positionSigma), rng.gaussian(positionSigma)));
}

struct Jitter {
    double position = 0.0; // RMS error, metres
    double angle = 0.0;    // RMS error, radians
};

TEST(PoseFilterTest, FirstUpdateReturnsTheMeasurementAndResetForgets) {
    PoseFilter filter;
    const Pose a(glm::angleAxis(0.3, glm::dvec3(0.0, 1.0, 0.0)), {1.0, 2.0, 3.0});
    EXPECT_DOUBLE_EQ(Pose::translationDistance(filter.update(a, dt), a), 0.0);
    const Pose b(glm::dquat(1.0, 0.0, 0.0, 0.0), {2.0, 2.0, 3.0});
    EXPECT_GT(Pose::translationDistance(filter.update(b, dt), b), 0.0);
    filter.reset();
    EXPECT_DOUBLE_EQ(Pose::translationDistance(filter.update(b, dt), b), 0.0);
}

TEST(PoseFilterTest, RemovesJitterAtRest) {
    cv::RNG rng(7);
    const Pose truth(glm::angleAxis(0.4, glm::normalize(glm::dvec3(1.0, 2.0, 0.5))), {0.2, -0.1, 1.0});
    PoseFilter filter;
    Jitter raw, filtered;
    int count = 0;
    for (int frame = 0; frame < 300; ++frame) {
        const Pose measurement = noisy(truth, rng, 0.001, 0.1 * std::numbers::pi / 180.0);
        const Pose output = filter.update(measurement, dt);
        if (frame < 30) continue; // settle
        raw.position += std::pow(Pose::translationDistance(measurement, truth), 2);
        raw.angle += std::pow(Pose::rotationAngleBetween(measurement, truth), 2);
        filtered.position += std::pow(Pose::translationDistance(output, truth), 2);
        filtered.angle += std::pow(Pose::rotationAngleBetween(output, truth), 2);
        ++count;
    }
    const double positionReduction = std::sqrt(raw.position / filtered.position);
    const double angleReduction = std::sqrt(raw.angle / filtered.angle);
    std::printf("at rest: jitter reduced %.1fx (position), %.1fx (rotation)\n", positionReduction, angleReduction);
    EXPECT_GT(positionReduction, 2.5);
    EXPECT_GT(angleReduction, 2.5);
}

// Lag = how far behind the truth the filtered pose is along the motion, divided by the speed:
// the time by which the output trails reality. Measured in steady motion (after 0.5 s).
TEST(PoseFilterTest, LagOnAMovingSequenceIsBelowOneFrame) {
    cv::RNG rng(11);
    const glm::dvec3 velocity(0.3, 0.1, 0.0); // 0.32 m/s: a slow hand-held pan
    const double angularSpeed = 0.5;          // rad/s (29 degrees/s) about y
    PoseFilter filter;
    double lagSum = 0.0, angularLagSum = 0.0;
    int count = 0;
    for (int frame = 0; frame < 60; ++frame) {
        const double t = frame * dt;
        const Pose truth(glm::angleAxis(angularSpeed * t, glm::dvec3(0.0, 1.0, 0.0)),
                         glm::dvec3(0.0, 0.0, 1.0) + velocity * t);
        const Pose output = filter.update(noisy(truth, rng, 0.001, 0.1 * std::numbers::pi / 180.0), dt);
        if (t < 0.5) continue;
        lagSum +=
            glm::dot(truth.translation() - output.translation(), glm::normalize(velocity)) / glm::length(velocity);
        angularLagSum += Pose::rotationAngleBetween(truth, output) / angularSpeed;
        ++count;
    }
    const double lag = lagSum / count;
    const double angularLag = angularLagSum / count;
    std::printf(
        "moving at %.2f m/s and %.0f deg/s: translation lag %.1f ms, rotation lag %.1f ms (one frame = 33.3 ms)\n",
        glm::length(velocity), angularSpeed * 180.0 / std::numbers::pi, lag * 1000.0, angularLag * 1000.0);
    EXPECT_LT(lag, dt);
    EXPECT_LT(angularLag, dt);
    EXPECT_GT(lag, -0.005); // no overshoot ahead of the truth either
}

TEST(PoseFilterTest, DisabledFilterPassesMeasurementsThrough) {
    PoseFilterSettings settings;
    settings.enabled = false;
    PoseFilter filter(settings);
    filter.update(Pose(), dt);
    const Pose b(glm::dquat(1.0, 0.0, 0.0, 0.0), {2.0, 0.0, 0.0});
    EXPECT_DOUBLE_EQ(Pose::translationDistance(filter.update(b, dt), b), 0.0);
}

} // namespace
} // namespace lightskin::tracking
