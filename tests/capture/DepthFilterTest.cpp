// Bilateral depth filter: edges kept, holes kept and not bleeding, noise reduced, and the same
// as cv::bilateralFilter where no hole is in reach.
#include <lightskin/capture/DepthFilter.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>

namespace lightskin::test {
namespace {

using capture::BilateralDepthFilter;

/// A plane tilted in x and y, ~2 m away, in millimetres (CV_16UC1) or metres (CV_32FC1).
cv::Mat planeMetres(int width, int height) {
    cv::Mat plane(height, width, CV_32FC1);
    for (int v = 0; v < height; ++v)
        for (int u = 0; u < width; ++u) plane.at<float>(v, u) = 2.0f + 0.0004f * float(u) + 0.0002f * float(v);
    return plane;
}

TEST(DepthFilterTest, ReducesNoiseOnANoisyPlaneByMoreThanThreeTimes) {
    const cv::Mat truth = planeMetres(320, 240);
    cv::Mat noisy = truth.clone(), noise(truth.size(), CV_32FC1);
    cv::RNG(7).fill(noise, cv::RNG::NORMAL, 0.0, 0.01); // 1 cm: Kinect v1 axial noise at ~2.3 m
    noisy += noise;
    BilateralDepthFilter filter;
    const cv::Mat filtered = filter.filter(noisy, 1.0);
    const cv::Rect inner(8, 8, 320 - 16, 240 - 16); // away from the image border
    const double before = cv::norm(noisy(inner), truth(inner), cv::NORM_L2) / std::sqrt(double(inner.area()));
    const double after = cv::norm(filtered(inner), truth(inner), cv::NORM_L2) / std::sqrt(double(inner.area()));
    std::printf("plane noise RMS: %.2f mm before, %.2f mm after (factor %.2f)\n", before * 1e3, after * 1e3,
                before / after);
    // An average of the 37 taps of a radius-3 disk would cut the noise by sqrt(37) = 6x; the
    // spatial fall-off (sigma 4.5 px) and the range weights (exp(-dz^2 / 2 (3 cm)^2) at the
    // 1.4 cm RMS difference of two noisy pixels) give about 4.5x here. Demand 3x.
    EXPECT_GT(before / after, 3.0);
}

TEST(DepthFilterTest, PreservesADepthEdge) {
    cv::Mat depth(60, 80, CV_16UC1, cv::Scalar(1000)); // 1.0 m
    depth(cv::Rect(40, 0, 40, 60)).setTo(1500);        // 1.5 m on the right half
    BilateralDepthFilter filter;
    const cv::Mat filtered = filter.filter(depth, 0.001);
    for (int v = 0; v < 60; ++v) {
        EXPECT_NEAR(filtered.at<float>(v, 39), 1.0f, 1e-5f);
        EXPECT_NEAR(filtered.at<float>(v, 40), 1.5f, 1e-5f);
    }
    // A plain Gaussian of the same spatial size would blur the 0.5 m step by decimetres.
    cv::Mat metres, blurred;
    depth.convertTo(metres, CV_32F, 0.001);
    cv::GaussianBlur(metres, blurred, cv::Size(7, 7), 4.5);
    EXPECT_GT(std::abs(blurred.at<float>(30, 39) - 1.0f), 0.05f);
}

TEST(DepthFilterTest, HolesStayHolesAndDoNotPullNeighboursTowardZero) {
    // Near depth (0.4 m) and a generous sigma_depth (0.2 m): here a zero neighbour's range
    // weight exp(-0.4^2 / 2 0.2^2) = 0.14 is far from negligible for cv::bilateralFilter.
    cv::Mat depth(48, 64, CV_16UC1, cv::Scalar(400));
    cv::RNG rng(3);
    for (int i = 0; i < 300; ++i) depth.at<std::uint16_t>(rng.uniform(0, 48), rng.uniform(0, 64)) = 0;
    depth(cv::Rect(20, 20, 10, 10)).setTo(0);
    capture::BilateralDepthFilterParams params;
    params.sigmaDepthMetres = 0.2;
    BilateralDepthFilter filter(params);
    const cv::Mat filtered = filter.filter(depth, 0.001);
    int holes = 0;
    for (int v = 0; v < 48; ++v)
        for (int u = 0; u < 64; ++u) {
            if (depth.at<std::uint16_t>(v, u) == 0) {
                ++holes;
                EXPECT_EQ(filtered.at<float>(v, u), 0.0f) << "hole filled at " << u << "," << v;
            } else {
                EXPECT_NEAR(filtered.at<float>(v, u), 0.4f, 1e-5f) << "pulled toward a hole at " << u << "," << v;
            }
        }
    EXPECT_GT(holes, 300);

    // The problem this guards against is real: cv::bilateralFilter on the raw metres is pulled.
    cv::Mat metres, plain;
    depth.convertTo(metres, CV_32F, 0.001);
    cv::bilateralFilter(metres, plain, 7, 0.2, 4.5, cv::BORDER_REPLICATE);
    EXPECT_LT(plain.at<float>(19, 25), 0.39f) << "a pixel next to the hole block";
}

TEST(DepthFilterTest, AgreesWithOpenCvAwayFromHoles) {
    cv::Mat metres = planeMetres(160, 120), noise(metres.size(), CV_32FC1);
    cv::RNG(11).fill(noise, cv::RNG::NORMAL, 0.0, 0.02);
    metres += noise;
    metres(cv::Rect(100, 30, 60, 40)) += 0.3f; // an object in front: a 30 cm step
    cv::Mat withHoles = metres.clone();
    withHoles(cv::Rect(10, 10, 8, 8)).setTo(0.0f);
    withHoles.at<float>(90, 50) = 0.0f;
    capture::BilateralDepthFilterParams params;
    BilateralDepthFilter filter(params);
    const cv::Mat ours = filter.filter(withHoles, 1.0);
    cv::Mat reference;
    cv::bilateralFilter(metres, reference, params.kernelSize, params.sigmaDepthMetres, params.sigmaSpacePixels,
                        cv::BORDER_REPLICATE);
    cv::Mat nearHole;
    cv::dilate(withHoles == 0.0f, nearHole, cv::Mat::ones(7, 7, CV_8U)); // every pixel whose disk reaches a hole
    int compared = 0;
    double worst = 0.0;
    for (int v = 0; v < 120; ++v)
        for (int u = 0; u < 160; ++u)
            if (!nearHole.at<std::uint8_t>(v, u)) {
                worst = std::max(worst, double(std::abs(ours.at<float>(v, u) - reference.at<float>(v, u))));
                ++compared;
            }
    EXPECT_GT(compared, 160 * 120 - 400);
    // The range-weight table OpenCV builds spans [min, max] of its input, which the hole sentinel
    // widens a little: differences stay far below a millimetre.
    EXPECT_LT(worst, 1e-4);
}

TEST(DepthFilterTest, RangeClampRemovesAndIsolatesOutOfRangeDepth) {
    cv::Mat depth(30, 30, CV_16UC1, cv::Scalar(1000));
    depth(cv::Rect(0, 0, 15, 30)).setTo(1020); // 2 cm step: within sigma_depth, blends
    depth.at<std::uint16_t>(15, 22) = 5000;    // 5 m: beyond the clamp
    capture::BilateralDepthFilterParams params;
    params.maxDepthMetres = 4.0;
    BilateralDepthFilter filter(params);
    cv::Mat out;
    filter.filterInto(depth, 0.001, out);
    EXPECT_EQ(out.at<float>(15, 22), 0.0f);
    EXPECT_NEAR(out.at<float>(15, 23), 1.0f, 1e-6f);
    const float* before = out.ptr<float>();
    filter.filterInto(depth, 0.001, out);
    EXPECT_EQ(out.ptr<float>(), before) << "filterInto reuses the output buffer";
}

} // namespace
} // namespace lightskin::test
