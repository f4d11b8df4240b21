#include "ExpectError.h"
#include "TestPaths.h"

#include <lightskin/core/Error.h>
#include <lightskin/eval/GoldenImage.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

namespace lightskin::test {
namespace {

cv::Mat gradient() {
    cv::Mat image(24, 32, CV_32FC3);
    for (int y = 0; y < image.rows; ++y)
        for (int x = 0; x < image.cols; ++x) image.at<cv::Vec3f>(y, x) = cv::Vec3f(float(x) / 32.0f, float(y) / 24.0f, 0.25f);
    return image;
}

// Exact match within 16-bit quantisation: one step is 1.5e-5 of the peak, so the relative MAE of
// an image against its own encoding is < 1e-4 of a signal whose mean is >= 0.25 / 3.
eval::GoldenThresholds strict() {
    eval::GoldenThresholds t;
    t.maxRelativeMeanAbsoluteError = 1e-4;
    t.maxAbsoluteError = 1e-3;
    return t;
}

TEST(GoldenImageTest, MissingGoldenIsReportedAndActualIsWritten) {
    const auto folder = scratchDir("golden_missing");
    const auto result =
        eval::compareWithGolden(gradient(), folder / "goldens", "frame", {}, folder / "out", {"test", {}, {}});
    EXPECT_TRUE(result.goldenMissing);
    EXPECT_FALSE(result.passed);
    EXPECT_TRUE(std::filesystem::exists(result.actualPath));
}

TEST(GoldenImageTest, PassesOnItsOwnOutputAndFailsWithDiffOnAChange) {
    const auto folder = scratchDir("golden_compare");
    eval::writeLinearPng16(folder / "goldens" / "frame.png", gradient(), "test renderer");

    const auto same = eval::compareWithGolden(gradient(), folder / "goldens", "frame", strict(), folder / "out",
                                              {"test renderer", {}, {}});
    EXPECT_TRUE(same.passed) << same.describe();
    EXPECT_FALSE(same.rendererMismatch);
    EXPECT_EQ(same.goldenRenderer, "test renderer");

    cv::Mat changed = gradient();
    changed(cv::Rect(4, 4, 8, 8)).setTo(cv::Scalar(1.0, 1.0, 1.0));
    const auto different = eval::compareWithGolden(changed, folder / "goldens", "frame", strict(), folder / "out",
                                                   {"test renderer", {}, {}});
    EXPECT_FALSE(different.passed);
    EXPECT_GT(different.error.maxAbsoluteError, 0.5);
    EXPECT_GT(different.error.relativeMeanAbsoluteError, 0.01);
    EXPECT_TRUE(std::filesystem::exists(different.diffPath));
    EXPECT_NE(different.describe().find(different.diffPath.string()), std::string::npos);
}

// The renderer recorded beside a golden is compared, not only printed: an identical image from
// another renderer fails, and the message names both renderers.
TEST(GoldenImageTest, RendererMismatchWithTheSidecarFails) {
    const auto folder = scratchDir("golden_renderer");
    eval::writeLinearPng16(folder / "goldens" / "frame.png", gradient(), "llvmpipe | Mesa 22.3.6");
    const auto result = eval::compareWithGolden(gradient(), folder / "goldens", "frame", strict(), folder / "out",
                                                {"llvmpipe | Mesa 23.1.0", {}, {}});
    EXPECT_TRUE(result.rendererMismatch);
    EXPECT_FALSE(result.passed);
    EXPECT_EQ(result.error.relativeMeanAbsoluteError, 0.0) << "the images themselves are equal";
    const std::string text = result.describe();
    EXPECT_NE(text.find("RENDERER MISMATCH"), std::string::npos) << text;
    EXPECT_NE(text.find("Mesa 22.3.6"), std::string::npos) << text;
    EXPECT_NE(text.find("Mesa 23.1.0"), std::string::npos) << text;
}

// Only covered pixels count, and with a baseline the error is relative to what the golden adds to
// it: a 10 % change of a signal covering 6 % of the image, on top of a base 3x brighter, reads 0.1.
// The files written beside the actual image reproduce the same numbers (what promotion shows).
TEST(GoldenImageTest, CoverageAndBaselineMakeTheErrorRelativeToTheSignal) {
    const auto folder = scratchDir("golden_coverage");
    const cv::Mat base(24, 32, CV_32FC3, cv::Scalar::all(0.6));
    cv::Mat signal = cv::Mat::zeros(24, 32, CV_32FC3);
    signal(cv::Rect(8, 8, 8, 6)).setTo(cv::Scalar::all(0.2));
    cv::Mat coverage = cv::Mat::zeros(24, 32, CV_8UC1);
    coverage(cv::Rect(6, 6, 12, 10)).setTo(255); // the content, a little wider than its signal
    eval::writeLinearPng16(folder / "goldens" / "frame.png", base + signal, "r");
    eval::GoldenThresholds t;
    t.maxRelativeMeanAbsoluteError = 0.05;
    for (const double k : {0.9, 1.1}) {
        const cv::Mat changed = base + k * signal;
        const auto result =
            eval::compareWithGolden(changed, folder / "goldens", "frame", t, folder / "out", {"r", coverage, base});
        // 16-bit quantisation of three images: a few 1e-5 on values of 0.6-0.8, relative to 0.2.
        EXPECT_NEAR(result.error.relativeMeanAbsoluteError, 0.1, 1e-3);
        EXPECT_EQ(result.error.pixelsCompared, 120u);
        EXPECT_FALSE(result.passed);
        std::string renderer;
        double peak = 0.0;
        const cv::Mat golden = eval::readLinearPng16(folder / "goldens" / "frame.png", renderer, peak);
        const eval::ImageError again = eval::compareCandidate(eval::readGoldenCandidate(result.actualPath), golden);
        EXPECT_EQ(again.relativeMeanAbsoluteError, result.error.relativeMeanAbsoluteError);
        EXPECT_EQ(again.pixelsCompared, result.error.pixelsCompared);
        // Without the baseline the same change is diluted by the base: 0.1 * 0.2 / 0.8 over the signal.
        const auto diluted =
            eval::compareWithGolden(changed, folder / "goldens", "frame", t, folder / "out2", {"r", coverage, {}});
        EXPECT_LT(diluted.error.relativeMeanAbsoluteError, 0.05);
        EXPECT_TRUE(diluted.passed) << "why the baseline is needed";
    }
    const auto same =
        eval::compareWithGolden(base + signal, folder / "goldens", "frame", t, folder / "out", {"r", coverage, base});
    EXPECT_TRUE(same.passed) << same.describe();
    EXPECT_THROW(eval::readGoldenCandidate(folder / "out" / "nothing.actual.png"), Error);
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

// A golden whose sidecar is missing or malformed, or whose PNG is not 16-bit, is an
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
    expectError(read, {"g.png", std::nullopt, "file is empty (0 bytes)"});
    std::filesystem::remove(png);
    expectError(read, {"g.png", std::nullopt, "missing or unreadable PNG"});
    // A golden (or its coverage) in another format never reaches OpenCV's other
    // decoders (Debian's GDCM aborts the process on some bytes): a BMP is refused by its magic.
    cv::imwrite(png.string() + ".bmp", cv::Mat(3, 4, CV_16UC1, cv::Scalar(7)));
    std::filesystem::rename(png.string() + ".bmp", png);
    expectError(read, {"g.png", std::nullopt, "not a PNG, TIFF or JPEG file"});
}

// The region metric on the replay suite's own goldens (the indirect views: the signal is the golden itself): the
// golden against itself passes; the indirect light lost by 20 % over a quarter of the covered pixels (a band from
// the left holding a quarter of them), or changed by 10 % over half, fails the replay suite's region limit while the
// whole-image relative MAE, which the loss dilutes by its share, may not; an all-zero image fails both.
TEST(GoldenImageTest, RegionMetricCatchesLocalLossesOnTheReplayGoldens) {
    constexpr double kReplayLimit = 0.05; // ReplayRegressionTest.cpp: relativeMaeAtMost(0.05), both metrics
    const auto leftShare = [](const cv::Mat& covered, double share) {
        const double total = double(cv::countNonZero(covered));
        cv::Mat part = cv::Mat::zeros(covered.size(), CV_8UC1);
        double counted = 0.0;
        for (int col = 0; col < covered.cols && counted < share * total; ++col) {
            covered.col(col).copyTo(part.col(col));
            counted += cv::countNonZero(covered.col(col));
        }
        return part;
    };
    int goldens = 0;
    for (const auto& entry : std::filesystem::directory_iterator(sourceDir() / "tests" / "replay" / "goldens")) {
        const std::string file = entry.path().filename().string();
        if (entry.path().extension() != ".png" || file.find("_indirect_") == std::string::npos) continue;
        SCOPED_TRACE(file);
        ++goldens;
        std::string renderer;
        double peak = 1.0;
        const cv::Mat golden = eval::readLinearPng16(entry.path(), renderer, peak);
        cv::Mat grey, covered;
        cv::cvtColor(golden, grey, cv::COLOR_BGR2GRAY);
        covered = grey > 0.0f;
        ASSERT_GT(cv::countNonZero(covered), 100) << "the golden must hold content";
        eval::ImageErrorOptions options{peak, covered, {}};
        options.regionGrid = eval::kGoldenRegionGrid;
        const eval::ImageError same = eval::compareImages(golden, golden, options);
        EXPECT_EQ(same.maxRegionRelativeMeanAbsoluteError, 0.0);
        EXPECT_GE(same.regionsCompared, 3u) << "the grid must cut the content into regions";
        struct Change {
            double share, factor;
        };
        for (const Change change : {Change{0.25, 0.8}, Change{0.5, 0.9}, Change{0.5, 1.1}}) {
            cv::Mat changed = golden.clone();
            cv::Mat scaled = golden * change.factor;
            scaled.copyTo(changed, leftShare(covered, change.share));
            const eval::ImageError e = eval::compareImages(changed, golden, options);
            std::printf("%s x %.1f over %.2f: relMAE %.4f, region relMAE %.4f\n", file.c_str(), change.factor,
                        change.share, e.relativeMeanAbsoluteError, e.maxRegionRelativeMeanAbsoluteError);
            EXPECT_GT(e.maxRegionRelativeMeanAbsoluteError, kReplayLimit)
                << "x " << change.factor << " over " << change.share << " of the content";
        }
        const eval::ImageError zero =
            eval::compareImages(cv::Mat::zeros(golden.size(), golden.type()), golden, options);
        EXPECT_GT(zero.relativeMeanAbsoluteError, kReplayLimit);
        EXPECT_GT(zero.maxRegionRelativeMeanAbsoluteError, kReplayLimit);
    }
    EXPECT_GE(goldens, 5) << "the replay goldens must be found";
}

} // namespace
} // namespace lightskin::test
