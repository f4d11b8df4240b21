#include <lightskin/synth/DepthNoise.h>
#include <lightskin/synth/Generator.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <set>

namespace lightskin::synth {
namespace {

// Normals that face the camera exactly along every pixel's ray (incidence angle 0).
cv::Mat normalsFacingTheCamera(const CameraIntrinsics& k) {
    cv::Mat normals(k.height, k.width, CV_32FC3);
    for (int v = 0; v < k.height; ++v)
        for (int u = 0; u < k.width; ++u) {
            const glm::dvec3 n = -glm::normalize(k.backProject(u, v, 1.0));
            normals.at<cv::Vec3f>(v, u) = cv::Vec3f(float(n.x), float(n.y), float(n.z));
        }
    return normals;
}

cv::Mat frontoParallelNormals(const CameraIntrinsics& k) { return cv::Mat(k.height, k.width, CV_32FC3, cv::Scalar(0, 0, -1)); }

DepthNoiseDescription enabledNoise() {
    DepthNoiseDescription noise;
    noise.enabled = true;
    noise.seed = 7;
    return noise;
}

const CameraIntrinsics qvga = CameraIntrinsics::kinectV1Default().scaledTo(320, 240);

TEST(DepthNoiseTest, DisabledNoiseCopiesTheExactDepth) {
    cv::Mat depth(qvga.height, qvga.width, CV_32FC1, cv::Scalar(1.2345));
    DepthNoiseDescription noise;
    cv::Mat out;
    applyDepthNoiseInto(depth, frontoParallelNormals(qvga), qvga, noise, 0, out);
    EXPECT_EQ(cv::norm(out, depth, cv::NORM_INF), 0.0);
}

TEST(DepthNoiseTest, PublishedAxialModelValues) {
    // Nguyen et al. 2012: sigma_z(z) = 0.0012 + 0.0019 (z - 0.4)^2.
    EXPECT_NEAR(kinectAxialSigmaMetres(1.0), 0.0012 + 0.0019 * 0.36, 1e-15);
    EXPECT_NEAR(kinectAxialSigmaMetres(3.0), 0.0012 + 0.0019 * 6.76, 1e-15);
    EXPECT_NEAR(kinectLateralSigmaPixels(0.0), 0.8, 1e-15);
    // Disparity step at 2 m for f = 580 px, b = 0.075 m, 1/8 px: z^2 / (f b 8).
    EXPECT_NEAR(disparityStepMetres(DepthNoiseDescription{}, 2.0), 4.0 / (580.0 * 0.075 * 8.0), 1e-15);
}

// The measured standard deviation of a fronto-parallel plane (stored as 16-bit millimetres, as
// a recording holds it) matches Nguyen et al.'s sigma_z within 10 %. With 76,800 pixels the
// sampling error of the std is ~0.3 %; the rest of the budget covers the approximation that
// disparity rounding adds q^2/12 of variance (Widrow: exact only when the noise before rounding
// is wide compared with the step q).
TEST(DepthNoiseTest, PlaneNoiseMatchesTheNguyenModelAt1To3Metres) {
    const DepthNoiseDescription noise = enabledNoise();
    for (const double z : {1.0, 2.0, 3.0}) {
        const cv::Mat depth(qvga.height, qvga.width, CV_32FC1, cv::Scalar(z));
        cv::Mat noisy, units;
        applyDepthNoiseInto(depth, frontoParallelNormals(qvga), qvga, noise, 3, noisy);
        depthMetresToUnitsInto(noisy, 0.001, units);
        cv::Mat metres;
        units.convertTo(metres, CV_64F, 0.001);
        cv::Scalar mean, stddev;
        cv::meanStdDev(metres, mean, stddev, units > 0);
        const double sigma = kinectAxialSigmaMetres(z);
        EXPECT_EQ(cv::countNonZero(units), qvga.width * qvga.height) << "no holes on a plane in range at " << z;
        EXPECT_NEAR(stddev[0], sigma, 0.10 * sigma) << "z = " << z;
        EXPECT_NEAR(mean[0], z, 0.2 * sigma) << "z = " << z;
        std::printf("plane at %.1f m: measured std %.5f m, model sigma_z %.5f m (ratio %.3f), mean error %+.5f m\n", z,
                    stddev[0], sigma, stddev[0] / sigma, mean[0] - z);
    }
}

TEST(DepthNoiseTest, DepthLiesOnTheDisparityGrid) {
    DepthNoiseDescription noise = enabledNoise();
    const double z = 3.0;
    const cv::Mat depth(qvga.height, qvga.width, CV_32FC1, cv::Scalar(z));
    cv::Mat noisy;
    applyDepthNoiseInto(depth, frontoParallelNormals(qvga), qvga, noise, 0, noisy);
    const double fb = noise.sensorFocalPixels * noise.baselineMetres;
    std::set<float> levels;
    for (int v = 0; v < noisy.rows; ++v)
        for (int u = 0; u < noisy.cols; ++u) {
            const double eighths = fb / double(noisy.at<float>(v, u)) * 8.0;
            ASSERT_NEAR(eighths, std::round(eighths), 1e-3);
            levels.insert(noisy.at<float>(v, u));
        }
    // sigma_z(3 m) = 1.4 cm against steps of 2.6 cm: a handful of levels, not a continuum.
    EXPECT_GE(levels.size(), 3u);
    EXPECT_LE(levels.size(), 12u);
}

TEST(DepthNoiseTest, IsReproducibleForASeedAndFrameAndDiffersOtherwise) {
    const DepthNoiseDescription noise = enabledNoise();
    const cv::Mat depth(qvga.height, qvga.width, CV_32FC1, cv::Scalar(2.0));
    const cv::Mat normals = frontoParallelNormals(qvga);
    cv::Mat a, b, c, d;
    applyDepthNoiseInto(depth, normals, qvga, noise, 5, a);
    applyDepthNoiseInto(depth, normals, qvga, noise, 5, b);
    applyDepthNoiseInto(depth, normals, qvga, noise, 6, c);
    DepthNoiseDescription otherSeed = noise;
    otherSeed.seed = 8;
    applyDepthNoiseInto(depth, normals, qvga, otherSeed, 5, d);
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
    // At 2 m the output takes only a few disparity levels, so many pixels agree by chance.
    EXPECT_GT(cv::countNonZero(a != c), a.total() / 4);
    EXPECT_GT(cv::countNonZero(a != d), a.total() / 4);
}

TEST(DepthNoiseTest, OutOfRangeDepthIsMissing) {
    const DepthNoiseDescription noise = enabledNoise();
    for (const double z : {0.45, 4.2}) {
        const cv::Mat depth(qvga.height, qvga.width, CV_32FC1, cv::Scalar(z));
        cv::Mat noisy;
        applyDepthNoiseInto(depth, frontoParallelNormals(qvga), qvga, noise, 0, noisy);
        EXPECT_EQ(cv::countNonZero(noisy), 0) << z;
    }
}

DepthNoiseDescription onlyGeometricHoles() {
    DepthNoiseDescription noise = enabledNoise();
    noise.axialNoise = false;
    noise.lateralNoise = false;
    noise.disparitySubpixel = 0.0;
    noise.edgeDropoutProbability = 0.0;
    noise.grazingStartDegrees = noise.grazingEndDegrees = 90.0;
    return noise;
}

// A box at 1 m (columns 100-149) in front of a wall at 2 m. The projector 7.5 cm to the right
// (+x) cannot light the wall over fx * b * (1/1 - 1/2) = 262.5 * 0.075 / 2 = 9.84 px left of the
// box: wall columns with u - 9.84 > 100 - 19.69, i.e. u = 91..99, are missing.
TEST(DepthNoiseTest, ProjectorShadowFallsBesideForegroundObjects) {
    cv::Mat depth(qvga.height, qvga.width, CV_32FC1, cv::Scalar(2.0));
    depth(cv::Rect(100, 0, 50, qvga.height)).setTo(1.0);
    cv::Mat noisy;
    applyDepthNoiseInto(depth, frontoParallelNormals(qvga), qvga, onlyGeometricHoles(), 0, noisy);
    for (int v = 0; v < qvga.height; v += 37) {
        EXPECT_GT(noisy.at<float>(v, 90), 0.0f);
        for (int u = 91; u <= 99; ++u) EXPECT_EQ(noisy.at<float>(v, u), 0.0f) << u;
        EXPECT_GT(noisy.at<float>(v, 100), 0.0f);
        EXPECT_GT(noisy.at<float>(v, 150), 0.0f); // the right side is lit
    }
    EXPECT_EQ(cv::countNonZero(noisy == 0.0f), 9 * qvga.height);

    // A projector on the left (-x) throws the shadow to the right of the box.
    DepthNoiseDescription left = onlyGeometricHoles();
    left.baselineMetres = -0.075;
    applyDepthNoiseInto(depth, frontoParallelNormals(qvga), qvga, left, 0, noisy);
    EXPECT_GT(noisy.at<float>(10, 99), 0.0f);
    for (int u = 150; u <= 158; ++u) EXPECT_EQ(noisy.at<float>(10, u), 0.0f) << u;
    EXPECT_GT(noisy.at<float>(10, 159), 0.0f);
}

// Surfaces seen at grazing angles lose depth: none beyond the end angle, a fraction in the ramp.
TEST(DepthNoiseTest, GrazingAnglesDropDepth) {
    DepthNoiseDescription noise = onlyGeometricHoles();
    noise.grazingStartDegrees = 70.0;
    noise.grazingEndDegrees = 82.0;
    const cv::Mat depth(qvga.height, qvga.width, CV_32FC1, cv::Scalar(2.0));
    const auto fractionKept = [&](double angleDegrees) {
        // Normals tilted by `angle` from the ray about an axis perpendicular to it.
        cv::Mat normals(qvga.height, qvga.width, CV_32FC3);
        const double a = angleDegrees * std::numbers::pi / 180.0;
        for (int v = 0; v < qvga.height; ++v)
            for (int u = 0; u < qvga.width; ++u) {
                const glm::dvec3 toCamera = -glm::normalize(qvga.backProject(u, v, 1.0));
                const glm::dvec3 side = glm::normalize(glm::cross(toCamera, glm::dvec3(0, 1, 0)));
                const glm::dvec3 n = std::cos(a) * toCamera + std::sin(a) * side;
                normals.at<cv::Vec3f>(v, u) = cv::Vec3f(float(n.x), float(n.y), float(n.z));
            }
        cv::Mat noisy;
        applyDepthNoiseInto(depth, normals, qvga, noise, 0, noisy);
        return double(cv::countNonZero(noisy)) / double(noisy.total());
    };
    EXPECT_EQ(fractionKept(60.0), 1.0);
    EXPECT_NEAR(fractionKept(76.0), 0.5, 0.01); // halfway up the ramp; 76,800 draws
    EXPECT_EQ(fractionKept(85.0), 0.0);
}

// Lateral noise: the pixel next to a vertical depth edge takes the far side's depth when its
// displacement N(0, sigma_L) rounds across the edge: probability 1 - Phi(0.5 / sigma).
TEST(DepthNoiseTest, LateralNoiseJittersEdgesWithTheNguyenSigma) {
    DepthNoiseDescription noise = onlyGeometricHoles();
    noise.projectorShadow = false;
    noise.lateralNoise = true;
    CameraIntrinsics tall{64, 4000, 262.5, 262.5, 31.5, 1999.5, {}};
    cv::Mat depth(tall.height, tall.width, CV_32FC1, cv::Scalar(2.0));
    depth(cv::Rect(32, 0, 32, tall.height)).setTo(1.0);
    cv::Mat noisy;
    applyDepthNoiseInto(depth, normalsFacingTheCamera(tall), tall, noise, 0, noisy);
    const double sigma = 0.8 * 262.5 / 580.0;
    const auto expectedCrossing = [&](double distance) { return 0.5 * std::erfc(distance / sigma / std::sqrt(2.0)); };
    for (const int column : {30, 31, 32, 33}) {
        const double crossed = double(cv::countNonZero(noisy.col(column) != depth.col(column))) / tall.height;
        const double distance = column < 32 ? 31.5 - column + 0.0 : column - 31.5;
        const double p = expectedCrossing(distance);
        const double tolerance = 4.0 * std::sqrt(p * (1 - p) / tall.height) + 1e-3;
        EXPECT_NEAR(crossed, p, tolerance) << "column " << column;
    }
    // Far from the edge nothing changes.
    EXPECT_EQ(cv::countNonZero(noisy.colRange(0, 28) != depth.colRange(0, 28)), 0);
}

TEST(DepthNoiseTest, DepthToUnitsRoundsAndMarksOverflowMissing) {
    cv::Mat metres = (cv::Mat_<float>(1, 4) << 0.0f, 1.0004f, 1.0006f, 70.0f);
    cv::Mat units;
    depthMetresToUnitsInto(metres, 0.001, units);
    EXPECT_EQ(units.at<std::uint16_t>(0, 0), 0);
    EXPECT_EQ(units.at<std::uint16_t>(0, 1), 1000);
    EXPECT_EQ(units.at<std::uint16_t>(0, 2), 1001);
    EXPECT_EQ(units.at<std::uint16_t>(0, 3), 0);
}

TEST(SrgbTest, EncodesAndDecodesTheIecCurve) {
    EXPECT_EQ(encodeSrgb(0.0f), 0);
    EXPECT_EQ(encodeSrgb(1.0f), 255);
    EXPECT_EQ(encodeSrgb(2.0f), 255);
    EXPECT_NEAR(decodeSrgb(128), 0.2158605f, 1e-6f); // (128/255 + 0.055)/1.055)^2.4
    EXPECT_EQ(encodeSrgb(0.0031308f), 10);             // the linear segment: 12.92 * 0.0031308 * 255 = 10.3
    for (int i = 0; i < 256; ++i) EXPECT_EQ(encodeSrgb(decodeSrgb(std::uint8_t(i))), i);
}

} // namespace
} // namespace lightskin::synth
