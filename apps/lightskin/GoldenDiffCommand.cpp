// `lightskin golden-diff <NAME.actual.png> <golden.png> [--diff PATH]`: what promoting an actual
// image to a golden would change, for scripts/promote_goldens.sh. Reads the actual image as
// eval::compareWithGolden wrote it (with its coverage and baseline, so the metrics are the ones the
// test computed), prints old-against-new: both renderers, the mean of the golden and of the actual
// over the covered pixels (and of what each adds to the baseline, e.g. the indirect light in a
// composite), the metrics, and writes the amplified difference image. A missing golden is reported
// as new (nothing to compare); a missing or unreadable actual image is an error (exit 1).
#include "CliSupport.h"
#include "Commands.h"
#include "ImageOutput.h"

#include <lightskin/core/Error.h>
#include <lightskin/eval/GoldenImage.h>

#include <opencv2/core.hpp>

#include <cstdio>
#include <filesystem>
#include <memory>

namespace lightskin::apps {

namespace {

struct GoldenDiffArgs {
    std::string actual, golden, diff;
};

/// Mean over pixels (where `coverage` is set, or all) and channels.
double coveredMean(const cv::Mat& image, const cv::Mat& coverage) {
    const cv::Scalar mean = cv::mean(image, coverage);
    double sum = 0.0;
    for (int c = 0; c < image.channels(); ++c) sum += mean[c];
    return sum / image.channels();
}

int runGoldenDiff(const GoldenDiffArgs& args) {
    if (!args.diff.empty()) checkImageOutput(args.diff, {args.actual, args.golden}, "--diff");
    const eval::GoldenCandidate candidate = eval::readGoldenCandidate(args.actual);
    const cv::Mat& coverage = candidate.coverage;
    const std::size_t covered =
        coverage.empty() ? candidate.image.total() : static_cast<std::size_t>(cv::countNonZero(coverage));
    std::printf("  new (actual): %s\n    renderer: %s\n    mean over %zu covered px: %.5f", args.actual.c_str(),
                candidate.renderer.c_str(), covered, coveredMean(candidate.image, coverage));
    if (!candidate.baseline.empty())
        std::printf(", added to the baseline: %.5f", coveredMean(candidate.image - candidate.baseline, coverage));
    std::printf("\n");
    if (!std::filesystem::exists(args.golden)) {
        std::printf("  old (golden): none, %s would be new\n", args.golden.c_str());
        return 0;
    }
    std::string goldenRenderer;
    double goldenPeak = 1.0;
    const cv::Mat golden = eval::readLinearPng16(args.golden, goldenRenderer, goldenPeak);
    if (golden.size() != candidate.image.size() || golden.type() != candidate.image.type())
        throw Error(args.golden, std::nullopt, "the golden's size or channels differ from " + args.actual);
    std::printf("  old (golden): %s\n    renderer: %s%s\n    mean over the same pixels: %.5f", args.golden.c_str(),
                goldenRenderer.c_str(), goldenRenderer == candidate.renderer ? "" : "  (DIFFERENT RENDERER)",
                coveredMean(golden, coverage));
    if (!candidate.baseline.empty())
        std::printf(", added to the baseline: %.5f", coveredMean(golden - candidate.baseline, coverage));
    std::printf("\n  new against old: %s\n", eval::compareCandidate(candidate, golden).describe().c_str());
    if (!args.diff.empty()) {
        eval::writeDiffImage(candidate.image, golden, candidate.linearPeak, args.diff);
        std::printf("  diff (|new - old| x 8): %s\n", args.diff.c_str());
    }
    return 0;
}

void addGoldenDiffCommand(CLI::App& app, int& exitCode) {
    auto* command =
        app.add_subcommand("golden-diff", "Compare an actual image written by a golden test with its golden "
                                          "(old against new, for scripts/promote_goldens.sh)");
    auto args = std::make_shared<GoldenDiffArgs>();
    command->add_option("actual", args->actual, "NAME.actual.png written by the test")->required();
    command->add_option("golden", args->golden, "The golden it would replace (may not exist yet)")->required();
    command->add_option("--diff", args->diff, "Write |new - old| amplified 8x to this PNG");
    command->callback([args, &exitCode] { exitCode = runGoldenDiff(*args); });
}

} // namespace

static const CommandRegistration registration{"golden-diff", &addGoldenDiffCommand};

} // namespace lightskin::apps
