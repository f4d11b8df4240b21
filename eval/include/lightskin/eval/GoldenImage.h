#pragma once
// Golden-image comparison for regression tests. A golden is a 16-bit PNG of a linear image
// (value * 65535 / `linearPeak`, so comparisons happen in linear space without 8-bit banding)
// with a JSON sidecar that records the renderer that produced it (e.g. llvmpipe / Mesa version)
// and the peak. On failure the actual image, the golden and an amplified diff are written next to
// each other under the output folder and their paths are returned for the test to print.
// Promote actual images to goldens with scripts/promote_goldens.sh.

#include <lightskin/eval/ImageMetrics.h>

#include <filesystem>
#include <string>

namespace lightskin::eval {

struct GoldenThresholds {
    double maxRelativeMse = 0.0;  ///< fail above
    double maxMeanAbsoluteError = 0.0;
    double maxAbsoluteError = 0.0;
    double minSsim = 1.0;         ///< fail below
};

struct GoldenResult {
    bool passed = false;
    bool goldenMissing = false;
    ImageError error;
    std::string goldenRenderer;   ///< renderer recorded with the golden
    std::filesystem::path actualPath, goldenPath, diffPath; ///< written on failure (or when missing: actual only)
    std::string describe() const;
};

/// Compares `linearImage` (CV_32FC3 or CV_32FC1) with `goldenFolder/name.png`. The actual image
/// is always written to `outputFolder/name.actual.png` (+ sidecar naming `renderer`), so that a
/// golden can be promoted from any run.
GoldenResult compareWithGolden(const cv::Mat& linearImage, const std::filesystem::path& goldenFolder,
                               const std::string& name, const GoldenThresholds& thresholds,
                               const std::filesystem::path& outputFolder, const std::string& renderer,
                               double linearPeak = 1.0);

/// Writes a linear float image as a golden-format 16-bit PNG with its sidecar.
void writeLinearPng16(const std::filesystem::path& path, const cv::Mat& linearImage, const std::string& renderer,
                      double linearPeak = 1.0);
/// Reads a golden-format PNG back to linear float; returns the sidecar's renderer in `renderer`.
cv::Mat readLinearPng16(const std::filesystem::path& path, std::string& renderer, double& linearPeak);

} // namespace lightskin::eval
