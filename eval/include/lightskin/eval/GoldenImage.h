#pragma once
// Golden-image comparison for regression tests. A golden is a 16-bit PNG of a linear image
// (value * 65535 / `linearPeak`, so comparisons happen in linear space without 8-bit banding)
// with a JSON sidecar that records the renderer that produced it (e.g. llvmpipe / Mesa version)
// and the peak. The comparison runs over the pixels that carry signal (a coverage mask), relative
// to the signal the golden must resolve, and fails when this run's renderer differs from the
// golden's. On failure the actual image, the golden and an amplified diff are written next to each
// other under the output folder and their paths are returned for the test to print.
// Promote actual images to goldens with scripts/promote_goldens.sh (it reads what is written here).

#include <lightskin/eval/ImageMetrics.h>

#include <filesystem>
#include <optional>
#include <string>

namespace lightskin::eval {

/// Pass/fail limits of a golden comparison. The relative MAE limit is required: a default-built
/// value (0) passes only an exact match. The others are optional (unset: reported, not checked);
/// a caller that sets one states its derivation.
struct GoldenThresholds {
    /// Fail above: ImageError::relativeMeanAbsoluteError (sum |actual - golden| / sum |signal| over
    /// the covered pixels; signal = golden - baseline when a baseline is given, else the golden).
    double maxRelativeMeanAbsoluteError = 0.0;
    std::optional<double> maxRelativeMse;       ///< fail above
    std::optional<double> maxMeanAbsoluteError; ///< fail above, linear units
    std::optional<double> maxAbsoluteError;     ///< fail above, linear units
    std::optional<double> minSsim;              ///< fail below
    /// Fail above: ImageError::maxRegionRelativeMeanAbsoluteError (the worst of kGoldenRegionGrid^2 regions of
    /// the covered pixels): catches a change confined to part of the content, which the whole-image relative MAE
    /// dilutes by the part's share.
    std::optional<double> maxRegionRelativeMeanAbsoluteError;
};

/// Regions per side of a golden comparison's region metric: 3 x 3 cells of the covered pixels' bounding box. A
/// change over a quarter of the content (a band from one side holding a quarter of the pixels) covers most of the
/// cells on that side, so a loss of 20 % there reads 0.07-0.20 on the replay goldens where the whole-image metric
/// reads 0.03-0.07; coarser grids dilute it like the whole image, finer ones leave small content (the synthetic
/// cubes cover ~1000 px) with cells of a few dozen pixels, where one silhouette pixel weighs more.
inline constexpr int kGoldenRegionGrid = 3;

/// What the comparison needs besides the image. Images are linear float like the image.
struct GoldenInputs {
    /// This run's renderer (e.g. report.json's `renderer`). A golden made by another renderer
    /// fails the comparison: llvmpipe is deterministic for one Mesa/LLVM version, not across them.
    std::string renderer;
    /// CV_8UC1 of the image's size: the pixels that carry signal (e.g. the virtual content); only
    /// these are compared. Empty: every pixel.
    cv::Mat coverage;
    /// The same frame without the effect the golden must resolve (e.g. the composite without GI):
    /// the relative MAE is then relative to |golden - baseline|. Empty: relative to the golden.
    cv::Mat baseline;
    double linearPeak = 1.0; ///< linear value stored as 65535
};

struct GoldenResult {
    bool passed = false;
    bool goldenMissing = false;
    bool rendererMismatch = false; ///< the golden's sidecar names another renderer (fails)
    ImageError error;
    std::string goldenRenderer;                             ///< renderer recorded with the golden
    std::string renderer;                                   ///< this run's renderer
    std::filesystem::path actualPath, goldenPath, diffPath; ///< written on failure (or when missing: actual only)
    std::string describe() const;
};

/// Compares `linearImage` (CV_32FC3 or CV_32FC1) with `goldenFolder/name.png`. The actual image
/// is always written to `outputFolder/name.actual.png` (+ sidecar naming the renderer), with the
/// coverage (`name.actual.coverage.png`) and baseline (`name.actual.baseline.png`) when given, so
/// that scripts/promote_goldens.sh can show the same metrics and promote it from any run.
GoldenResult compareWithGolden(const cv::Mat& linearImage, const std::filesystem::path& goldenFolder,
                               const std::string& name, const GoldenThresholds& thresholds,
                               const std::filesystem::path& outputFolder, const GoldenInputs& inputs);

/// An actual image as compareWithGolden wrote it, read back from `name.actual.png` and its files.
struct GoldenCandidate {
    cv::Mat image, coverage, baseline; ///< coverage/baseline empty when they were not written
    std::string renderer;
    double linearPeak = 1.0;
};
/// Throws lightskin::Error naming the file when the actual image or its sidecar is missing or bad.
GoldenCandidate readGoldenCandidate(const std::filesystem::path& actualPng);
/// The metrics compareWithGolden computes for `candidate` against the golden image `golden`.
ImageError compareCandidate(const GoldenCandidate& candidate, const cv::Mat& golden);
/// Writes |actual - golden| amplified 8x as an 8-bit PNG (linear units / peak). Throws on failure.
void writeDiffImage(const cv::Mat& actual, const cv::Mat& golden, double linearPeak, const std::filesystem::path& path);

/// Writes a linear float image as a golden-format 16-bit PNG with its sidecar.
void writeLinearPng16(const std::filesystem::path& path, const cv::Mat& linearImage, const std::string& renderer,
                      double linearPeak = 1.0);
/// Reads a golden-format PNG back to linear float; returns the sidecar's renderer in `renderer`.
cv::Mat readLinearPng16(const std::filesystem::path& path, std::string& renderer, double& linearPeak);

} // namespace lightskin::eval
