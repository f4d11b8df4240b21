#include "ExpectError.h"
#include "TestPaths.h"

#include <lightskin/eval/GoldenImage.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <fstream>

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

// Issue 21 part 5: a golden whose sidecar is missing or malformed, or whose PNG is not 16-bit, is an
// error naming the file and the cause (never a golden read with a made-up peak).
TEST(GoldenImageTest, MalformedSidecarOrPngIsAnErrorNamingTheFile) {
    const auto folder = scratchDir("golden_malformed");
    const auto png = folder / "g.png", sidecar = folder / "g.json";
    const auto read = [&] {
        std::string renderer;
        double peak = 0.0;
        (void)eval::readLinearPng16(png, renderer, peak);
    };
    eval::writeLinearPng16(png, gradient(), "r", 1.0);
    std::filesystem::remove(sidecar);
    expectError(read, {"g.json", std::nullopt, "missing golden sidecar"});
    const std::pair<const char*, const char*> cases[] = {
        {R"({"renderer": "r", "linearPeak": )", "malformed sidecar"},
        {R"({"linearPeak": 1.0})", "malformed sidecar"}, // no renderer
        {R"({"renderer": "r", "linearPeak": "one"})", "malformed sidecar"},
        {R"({"renderer": "r", "linearPeak": 1e999})", "number overflow"},
        {R"({"renderer": "r", "linearPeak": 0})", "linearPeak must be positive"},
        {R"({"renderer": "r", "linearPeak": -2})", "linearPeak must be positive"},
    };
    for (const auto& [text, cause] : cases) {
        std::ofstream(sidecar, std::ios::trunc) << text;
        expectError(read, {"g.json", std::nullopt, cause});
    }
    std::ofstream(sidecar, std::ios::trunc) << R"({"renderer": "r", "linearPeak": 1.0})";
    cv::imwrite(png.string(), cv::Mat(3, 4, CV_8UC3, cv::Scalar(1, 2, 3)));
    expectError(read, {"g.png", std::nullopt, "a golden must be a 16-bit PNG"});
    std::ofstream(png, std::ios::trunc) << "";
    expectError(read, {"g.png", std::nullopt, "missing or unreadable PNG"});
}

} // namespace
} // namespace lightskin::test
