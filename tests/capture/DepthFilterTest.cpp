// Bilateral depth filter: edges kept, holes kept and not bleeding, noise reduced, and the same
// as cv::bilateralFilter where no hole is in reach; the SIMD implementation against a separately
// written double-precision filter, and on a step edge with the Kinect v1 noise model (FACTS.md).
#include <lightskin/capture/DepthFilter.h>
#include <lightskin/core/SimdTarget.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <tuple>
#include <vector>

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

/// The masked bilateral filter of DepthFilter.h written out in double with std::exp, for the
/// SIMD kernel to be checked against (independent of it: no tables, no polynomial, no padding).
/// Also returns, per pixel, the bound of the float kernel's rounding (see the test below).
struct DoubleFilterResult {
    cv::Mat out, bound; // CV_64FC1
};
DoubleFilterResult doubleBilateral(const cv::Mat& metres, const capture::BilateralDepthFilterParams& p) {
    const int radius = p.kernelSize / 2;
    DoubleFilterResult r{cv::Mat(metres.size(), CV_64FC1, cv::Scalar(0.0)),
                         cv::Mat(metres.size(), CV_64FC1, cv::Scalar(0.0))};
    const auto at = [&](int v, int u) { // BORDER_REPLICATE
        return double(metres.at<float>(std::clamp(v, 0, metres.rows - 1), std::clamp(u, 0, metres.cols - 1)));
    };
    constexpr double kUnit = 0x1p-24; // float's unit roundoff
    const int taps = 28;
    for (int v = 0; v < metres.rows; ++v)
        for (int u = 0; u < metres.cols; ++u) {
            const double z0 = at(v, u);
            if (!(z0 > 0.0)) continue;
            double sum = 0.0, weights = 0.0;
            std::vector<std::pair<double, double>> terms; // (weight, z)
            for (int i = -radius; i <= radius; ++i)
                for (int j = -radius; j <= radius; ++j) {
                    if (std::sqrt(double(i * i + j * j)) > double(radius)) continue;
                    const double z = at(v + i, u + j);
                    if (!(z > 0.0)) continue;
                    const double w = std::exp(-double(i * i + j * j) / (2.0 * p.sigmaSpacePixels * p.sigmaSpacePixels) -
                                              (z - z0) * (z - z0) / (2.0 * p.sigmaDepthMetres * p.sigmaDepthMetres));
                    sum += w * z;
                    weights += w;
                    terms.emplace_back(w, z);
                }
            const double result = sum / weights;
            // The float kernel's error (BilateralDepthKernel.cpp): each weight 2^y with y = log2 s -
            // (c dz)^2 has a relative error <= 2.9e-7 (exp2 polynomial) + ln 2 * 3 u (|y| + 1) (the
            // roundings of c dz, its square and the FMA carry to y's absolute error); a weight error
            // dw moves the result by dw |z - result| / W. The two running sums (29 float terms each)
            // and the division: (2 * 29 + 1) u of the result.
            double weightTerm = 0.0;
            for (const auto& [w, z] : terms) {
                const double y = std::log2(w);
                weightTerm += w * (2.9e-7 + std::log(2.0) * 3.0 * kUnit * (std::abs(y) + 1.0)) * std::abs(z - result);
            }
            r.out.at<double>(v, u) = result;
            r.bound.at<double>(v, u) = weightTerm / weights + (2.0 * (taps + 1) + 1.0) * kUnit * result;
        }
    return r;
}

/// Two planes (1.2 m left, 2.0 m right of column 320) with the Kinect v1 axial noise of FACTS.md
/// (Nguyen et al. 2012: sigma_z = 0.0012 + 0.0019 (z - 0.4)^2 m: 2.4 mm at 1.2 m, 6.1 mm at 2 m),
/// `holes` of the pixels missing (0). Millimetres, as a Kinect delivers them (CV_16UC1), would quantise
/// the 2.4 mm noise; metres in float keep the model.
cv::Mat kinectStep(cv::Mat* truth, double holes) {
    cv::Mat depth(480, 640, CV_32FC1);
    cv::RNG rng(18);
    if (truth) *truth = cv::Mat(depth.size(), CV_32FC1);
    for (int v = 0; v < depth.rows; ++v)
        for (int u = 0; u < depth.cols; ++u) {
            const double z = u < 320 ? 1.2 : 2.0;
            const double sigma = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
            depth.at<float>(v, u) = float(z + rng.gaussian(sigma));
            if (truth) truth->at<float>(v, u) = float(z);
            if (rng.uniform(0.0, 1.0) < holes) depth.at<float>(v, u) = 0.0f;
        }
    return depth;
}

// Every instruction set this CPU supports (core/SimdTarget.h), so the SSE4 and AVX2 kernels older CPUs
// run are proven too; the test's name carries the target.
class DepthFilterSimdTest : public ::testing::TestWithParam<std::string> {};

TEST_P(DepthFilterSimdTest, MatchesADoublePrecisionFilterWithinItsRoundingBound) {
    const core::SimdTargetScope target(GetParam());
    cv::Mat depth = kinectStep(nullptr, 0.05);
    depth(cv::Rect(100, 100, 12, 9)).setTo(0.0f); // a hole block
    capture::BilateralDepthFilterParams params;   // the replay's (KinectFusion) parameters
    BilateralDepthFilter filter(params);
    const cv::Mat ours = filter.filter(depth, 1.0);
    const DoubleFilterResult reference = doubleBilateral(depth, params);
    int compared = 0, holes = 0;
    double worstRatio = 0.0, worst = 0.0;
    for (int v = 0; v < depth.rows; ++v)
        for (int u = 0; u < depth.cols; ++u) {
            if (depth.at<float>(v, u) == 0.0f) {
                EXPECT_EQ(ours.at<float>(v, u), 0.0f) << "hole filled at " << u << "," << v;
                ++holes;
                continue;
            }
            const double error = std::abs(double(ours.at<float>(v, u)) - reference.out.at<double>(v, u));
            worst = std::max(worst, error);
            worstRatio = std::max(worstRatio, error / reference.bound.at<double>(v, u));
            ++compared;
        }
    std::printf("%s vs double: worst %.3g m, %.3g of the per-pixel bound\n", GetParam().c_str(), worst, worstRatio);
    EXPECT_GT(holes, 15000);
    EXPECT_GT(compared, 280000);
    EXPECT_LE(worstRatio, 1.0);
}

INSTANTIATE_TEST_SUITE_P(EveryInstructionSet, DepthFilterSimdTest, ::testing::ValuesIn(core::simdTargets()),
                         [](const ::testing::TestParamInfo<std::string>& target) { return target.param; });

TEST(DepthFilterTest, KeepsAKinectStepEdgeAndReducesItsNoiseAsTheSpatialWeightsPredict) {
    cv::Mat truth;
    const cv::Mat depth = kinectStep(&truth, 0.05);
    capture::BilateralDepthFilterParams params;
    BilateralDepthFilter filter(params);
    const cv::Mat out = filter.filter(depth, 1.0);

    // Edge: across the 0.8 m step a tap's range weight is below exp(-(0.8 - 0.05)^2 / (2 * 0.03^2))
    // = e^-312 (the noise is < 8 sigma = 5 cm): 0 in float, so each side is filtered from its own
    // taps alone. The last left column then averages 1.2 m samples only: its mean lies within 5
    // standard errors of 1.2 m (sigma_z / sqrt(rows) bounds the error of a mean of filtered values,
    // which are averages of the noise), and no pixel of it leaves [1.2 - 6 sigma_z, 1.2 + 6 sigma_z].
    const double sigmaNear = 0.0012 + 0.0019 * 0.8 * 0.8, sigmaFar = 0.0012 + 0.0019 * 1.6 * 1.6;
    for (const auto& [column, z, sigma] : {std::tuple{319, 1.2, sigmaNear}, std::tuple{320, 2.0, sigmaFar}}) {
        double sum = 0.0;
        int n = 0;
        for (int v = 0; v < out.rows; ++v) {
            const float f = out.at<float>(v, column);
            if (depth.at<float>(v, column) == 0.0f) {
                EXPECT_EQ(f, 0.0f);
                continue;
            }
            EXPECT_NEAR(f, z, 6.0 * sigma) << "edge pixel " << column << "," << v;
            sum += double(f);
            ++n;
        }
        EXPECT_NEAR(sum / n, z, 5.0 * sigma / std::sqrt(double(n))) << "column " << column;
    }

    // Noise on the 1.2 m plane (the same scene without holes), at pixels 7 apart (disjoint taps:
    // independent outputs), >= 3 px from the edge and the border. With range weights ~1 the output
    // is the spatially weighted mean of 29 samples: its standard deviation is sigma_z sqrt(sum s^2) /
    // sum s (s = exp(-r^2 / 2 sigma_space^2), centre 1). The range weights exp(-dz^2 / 2
    // sigma_depth^2), dz ~ N(0, 2 sigma_z^2), average 1 - sigma_z^2 / sigma_depth^2 = 1 - 0.64 %:
    // they change that ratio by at most twice that, 1.3 %. The sample standard deviation of n
    // independent outputs has a relative standard error 1 / sqrt(2 n) (1.3 % for n ~ 3000): 5 of
    // them, 6.4 %. Tolerance 1.3 % + 5 / sqrt(2 n).
    const cv::Mat whole = kinectStep(nullptr, 0.0);
    const cv::Mat wholeOut = filter.filter(whole, 1.0);
    double sumS = 1.0, sumS2 = 1.0;
    for (int i = -3; i <= 3; ++i)
        for (int j = -3; j <= 3; ++j)
            if ((i != 0 || j != 0) && i * i + j * j <= 9) {
                const double s = std::exp(-double(i * i + j * j) / (2.0 * 4.5 * 4.5));
                sumS += s, sumS2 += s * s;
            }
    const double predicted = std::sqrt(sumS2) / sumS;
    double sum = 0.0, sum2 = 0.0;
    int n = 0;
    for (int v = 3; v < wholeOut.rows - 3; v += 7)
        for (int u = 3; u < 320 - 3; u += 7) {
            const double e = double(wholeOut.at<float>(v, u)) - 1.2;
            sum += e, sum2 += e * e;
            ++n;
        }
    const double mean = sum / n, stddev = std::sqrt(sum2 / n - mean * mean);
    const double tolerance = 0.013 + 5.0 / std::sqrt(2.0 * n);
    std::printf("1.2 m plane: filtered noise %.3f mm = %.4f of sigma_z, predicted %.4f (n = %d, tolerance %.1f %%)\n",
                stddev * 1e3, stddev / sigmaNear, predicted, n, 100.0 * tolerance);
    EXPECT_GT(n, 2000);
    EXPECT_NEAR(stddev / sigmaNear / predicted, 1.0, tolerance);
}

} // namespace
} // namespace lightskin::test
