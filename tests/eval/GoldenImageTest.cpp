#include "TestPaths.h"

#include <lightskin/eval/GoldenImage.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

namespace lightskin::test {
namespace {

cv::Mat gradient() {
    cv::Mat image(24, 32, CV_32FC3);
    for (int y = 0; y < image.rows; ++y)
        for (int x = 0; x < image.cols; ++x) image.at<cv::Vec3f>(y, x) = cv::Vec3f(float(x) / 32.0f, float(y) / 24.0f, 0.25f);
    return image;
}

TEST(GoldenImageTest, MissingGoldenIsReportedAndActualIsWritten) {
    const auto folder = scratchDir("golden_missing");
    const auto result = eval::compareWithGolden(gradient(), folder / "goldens", "frame", {}, folder / "out", "test");
    EXPECT_TRUE(result.goldenMissing);
    EXPECT_FALSE(result.passed);
    EXPECT_TRUE(std::filesystem::exists(result.actualPath));
}

TEST(GoldenImageTest, PassesOnItsOwnOutputAndFailsWithDiffOnAChange) {
    const auto folder = scratchDir("golden_compare");
    const eval::GoldenThresholds strict{1e-8, 1e-4, 1e-3, 0.999};
    eval::writeLinearPng16(folder / "goldens" / "frame.png", gradient(), "test renderer");

    const auto same = eval::compareWithGolden(gradient(), folder / "goldens", "frame", strict, folder / "out", "test");
    EXPECT_TRUE(same.passed) << same.describe();
    EXPECT_EQ(same.goldenRenderer, "test renderer");

    cv::Mat changed = gradient();
    changed(cv::Rect(4, 4, 8, 8)).setTo(cv::Scalar(1.0, 1.0, 1.0));
    const auto different = eval::compareWithGolden(changed, folder / "goldens", "frame", strict, folder / "out", "test");
    EXPECT_FALSE(different.passed);
    EXPECT_GT(different.error.maxAbsoluteError, 0.5);
    EXPECT_TRUE(std::filesystem::exists(different.diffPath));
    EXPECT_NE(different.describe().find(different.diffPath.string()), std::string::npos);
}

TEST(GoldenImageTest, SixteenBitEncodingRoundTripsWithinQuantisation) {
    const auto folder = scratchDir("golden_roundtrip");
    eval::writeLinearPng16(folder / "g.png", gradient(), "r", 2.0);
    std::string renderer;
    double peak = 0.0;
    const cv::Mat back = eval::readLinearPng16(folder / "g.png", renderer, peak);
    EXPECT_EQ(peak, 2.0);
    EXPECT_LE(cv::norm(back, gradient(), cv::NORM_INF), 2.0 / 65535.0);
}

} // namespace
} // namespace lightskin::test
