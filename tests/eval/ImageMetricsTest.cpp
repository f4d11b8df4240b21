#include <lightskin/core/Error.h>
#include <lightskin/eval/ColourSpace.h>
#include <lightskin/eval/ImageMetrics.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <limits>

namespace lightskin::test {
namespace {

TEST(ColourSpaceTest, MatchesTheSrgbStandardAndRoundTrips) {
    EXPECT_FLOAT_EQ(eval::srgbToLinear(0.0f), 0.0f);
    EXPECT_FLOAT_EQ(eval::srgbToLinear(1.0f), 1.0f);
    EXPECT_NEAR(eval::srgbToLinear(0.5f), 0.21404f, 1e-5f); // IEC 61966-2-1
    EXPECT_NEAR(eval::srgbToLinear(0.04045f), 0.04045f / 12.92f, 1e-7f);
    for (int i = 0; i < 256; ++i) {
        const float encoded = float(i) / 255.0f;
        EXPECT_NEAR(eval::linearToSrgb(eval::srgbToLinear(encoded)), encoded, 1e-5f);
    }
    cv::Mat srgb(2, 2, CV_8UC3, cv::Scalar(0, 128, 255)), linear, back;
    eval::srgb8ToLinearInto(srgb, linear);
    eval::linearToSrgb8Into(linear, back);
    EXPECT_EQ(cv::norm(srgb, back, cv::NORM_INF), 0.0);
}

TEST(ImageMetricsTest, IdenticalImagesHaveNoError) {
    cv::Mat image(32, 32, CV_32FC3);
    cv::randu(image, 0.0, 1.0);
    const eval::ImageError error = eval::compareImages(image, image);
    EXPECT_EQ(error.relativeMse, 0.0);
    EXPECT_EQ(error.maxAbsoluteError, 0.0);
    EXPECT_NEAR(error.ssim, 1.0, 1e-9);
    EXPECT_TRUE(std::isinf(error.psnr));
    EXPECT_EQ(error.pixelsCompared, 32u * 32u);
}

TEST(ImageMetricsTest, ConstantOffsetGivesTheAnalyticValues) {
    const cv::Mat reference(16, 16, CV_32FC1, cv::Scalar(0.5));
    const cv::Mat image(16, 16, CV_32FC1, cv::Scalar(0.6));
    const eval::ImageError error = eval::compareImages(image, reference);
    EXPECT_NEAR(error.relativeMse, 0.01 / (0.25 + 0.01), 1e-6);
    EXPECT_NEAR(error.meanAbsoluteError, 0.1, 1e-6);
    EXPECT_NEAR(error.maxAbsoluteError, 0.1, 1e-6);
    EXPECT_NEAR(error.psnr, 20.0, 1e-4); // 10 log10(1 / 0.01)
}

TEST(ImageMetricsTest, SsimDropsWithStructuralDamageAndMaskRestrictsPixels) {
    cv::Mat reference(64, 64, CV_32FC1);
    cv::randu(reference, 0.0, 1.0);
    cv::GaussianBlur(reference, reference, cv::Size(5, 5), 1.0);
    cv::Mat blurred;
    cv::GaussianBlur(reference, blurred, cv::Size(9, 9), 3.0);
    const double blurredSsim = eval::compareImages(blurred, reference).ssim;
    EXPECT_LT(blurredSsim, 0.9);
    EXPECT_GT(blurredSsim, 0.0);

    cv::Mat damaged = reference.clone();
    damaged(cv::Rect(0, 0, 32, 64)).setTo(0.0);
    cv::Mat mask(64, 64, CV_8UC1, cv::Scalar(0));
    mask(cv::Rect(32, 0, 32, 64)).setTo(255);
    const eval::ImageError maskedError = eval::compareImages(damaged, reference, {1.0, mask, {}});
    EXPECT_EQ(maskedError.maxAbsoluteError, 0.0);
    EXPECT_EQ(maskedError.pixelsCompared, 32u * 64u);
}

TEST(ImageMetricsTest, RejectsMismatchedAndNonFiniteImages) {
    const cv::Mat a(8, 8, CV_32FC1, cv::Scalar(0.0)), b(8, 9, CV_32FC1, cv::Scalar(0.0));
    EXPECT_THROW((void)eval::compareImages(a, b), Error);
    cv::Mat nan = a.clone();
    nan.at<float>(3, 3) = std::numeric_limits<float>::quiet_NaN();
    EXPECT_EQ(eval::countNonFinite(nan), 1u);
    EXPECT_THROW((void)eval::compareImages(nan, a), Error);
    EXPECT_THROW((void)eval::compareImages(a, nan), Error);
}

// Relative MAE is what golden thresholds are derived from: a uniform change of the signal by a
// factor k must read |k - 1| exactly, whatever the zeros around it and whatever else the reference
// holds (the signal option: e.g. the indirect light inside a composite).
TEST(ImageMetricsTest, RelativeMaeReadsAUniformChangeOfTheSignalExactly) {
    cv::Mat reference = cv::Mat::zeros(40, 40, CV_32FC3);
    cv::Mat content = reference(cv::Rect(10, 10, 8, 8)); // 4 % of the image carries signal
    cv::randu(content, 0.05, 0.5);
    cv::Mat mask = cv::Mat::zeros(40, 40, CV_8UC1);
    mask(cv::Rect(10, 10, 8, 8)).setTo(255);
    for (const double k : {0.9, 1.1}) {
        const cv::Mat scaled = reference * k;
        EXPECT_NEAR(eval::compareImages(scaled, reference).relativeMeanAbsoluteError, std::abs(k - 1.0), 1e-6);
        const eval::ImageError masked = eval::compareImages(scaled, reference, {1.0, mask, {}});
        EXPECT_NEAR(masked.relativeMeanAbsoluteError, std::abs(k - 1.0), 1e-6);
        EXPECT_EQ(masked.pixelsCompared, 64u);
        // Over the mask the MAE is 25x the whole image's (the zeros no longer dilute it).
        EXPECT_NEAR(masked.meanAbsoluteError / eval::compareImages(scaled, reference).meanAbsoluteError, 25.0, 1e-3);
    }
    // A composite = base + signal; the signal alone changed by 10 %: 0.1 relative to the signal.
    cv::Mat base(40, 40, CV_32FC3, cv::Scalar(0.3, 0.4, 0.5));
    const cv::Mat composite = base + reference, changed = base + 0.9 * reference;
    const cv::Mat signal = composite - base;
    EXPECT_NEAR(eval::compareImages(changed, composite, {1.0, mask, signal}).relativeMeanAbsoluteError, 0.1, 1e-5);
    // Against the whole composite the same change reads far less: why the signal option exists.
    EXPECT_LT(eval::compareImages(changed, composite, {1.0, mask, {}}).relativeMeanAbsoluteError, 0.05);
    // No signal: 0 when equal, +inf when not.
    const cv::Mat zeros = cv::Mat::zeros(4, 4, CV_32FC3), small = cv::Mat(4, 4, CV_32FC3, cv::Scalar::all(1e-3));
    EXPECT_EQ(eval::compareImages(zeros, zeros).relativeMeanAbsoluteError, 0.0);
    EXPECT_TRUE(std::isinf(eval::compareImages(small, zeros).relativeMeanAbsoluteError));
    EXPECT_THROW(eval::compareImages(zeros, zeros, {1.0, {}, cv::Mat::zeros(3, 4, CV_32FC3)}), Error);
}

// The region metric: a change over one cell of the grid reads |k - 1| there however small the cell's share of the
// image (where the whole-image metric reads the share times that), cells holding less than half their share are
// skipped, and a cell far darker than the image's mean is judged against 0.1 of the mean (its noise cannot blow up).
TEST(ImageMetricsTest, RegionMetricReadsALocalChangeUndiluted) {
    cv::Mat reference(30, 30, CV_32FC3, cv::Scalar::all(0.2));
    eval::ImageErrorOptions options;
    options.regionGrid = 3; // 10 x 10 px cells
    options.minRegionPixels = 32;
    cv::Mat changed = reference.clone();
    changed(cv::Rect(0, 0, 10, 10)) *= 0.8; // one cell of nine
    eval::ImageError e = eval::compareImages(changed, reference, options);
    EXPECT_EQ(e.regionsCompared, 9u);
    EXPECT_NEAR(e.maxRegionRelativeMeanAbsoluteError, 0.2, 1e-6);
    EXPECT_NEAR(e.relativeMeanAbsoluteError, 0.2 / 9.0, 1e-6);
    // Off unless asked for.
    EXPECT_EQ(eval::compareImages(changed, reference).maxRegionRelativeMeanAbsoluteError, 0.0);
    // A mask leaving 20 px of the top-left cell (< half its share of 500 / 9): skipped.
    cv::Mat mask(30, 30, CV_8UC1, cv::Scalar(255));
    mask(cv::Rect(0, 0, 10, 10)).setTo(0);
    mask(cv::Rect(0, 0, 10, 2)).setTo(255);
    options.mask = mask;
    e = eval::compareImages(changed, reference, options);
    EXPECT_EQ(e.regionsCompared, 8u);
    EXPECT_LT(e.maxRegionRelativeMeanAbsoluteError, 1e-6);
    // A cell at 1 % of the mean signal: its change of 1e-3 is judged against 0.1 of the mean, not its own light.
    options.mask = cv::Mat();
    reference(cv::Rect(20, 20, 10, 10)).setTo(cv::Scalar::all(0.002));
    changed = reference.clone();
    changed(cv::Rect(20, 20, 10, 10)).setTo(cv::Scalar::all(0.003));
    e = eval::compareImages(changed, reference, options);
    const double mean = (8.0 * 0.2 + 0.002) / 9.0;
    EXPECT_NEAR(e.maxRegionRelativeMeanAbsoluteError, 0.001 / (0.1 * mean), 1e-4);
}

} // namespace
} // namespace lightskin::test
