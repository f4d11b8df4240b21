#include <lightskin/core/Error.h>
#include <lightskin/core/JsonError.h>
#include <lightskin/core/ImageFile.h>
#include <lightskin/eval/GoldenImage.h>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <fstream>

namespace lightskin::eval {

namespace {
std::filesystem::path sidecarOf(const std::filesystem::path& png) {
    std::filesystem::path sidecar = png;
    sidecar.replace_extension(".json");
    return sidecar;
}

/// NAME.actual.png -> NAME.actual<suffix>: the files written beside an actual image.
std::filesystem::path withSuffix(const std::filesystem::path& actualPng, const char* suffix) {
    std::filesystem::path path = actualPng;
    path.replace_extension(suffix);
    return path;
}
} // namespace

std::string GoldenResult::describe() const {
    if (goldenMissing) return "golden missing: " + goldenPath.string() + " (actual written to " + actualPath.string() + ")";
    std::string text = (passed ? "passed: " : "FAILED: ") + error.describe();
    if (rendererMismatch)
        text += "\n  RENDERER MISMATCH: the golden was made by '" + goldenRenderer + "', this run is '" + renderer +
                "' (llvmpipe output is reproducible only for one Mesa/LLVM version): review the diff and the metrics, "
                "then promote with scripts/promote_goldens.sh ... --accept (docs/TESTING.md)";
    if (!passed)
        text += "\n  actual: " + actualPath.string() + "\n  golden: " + goldenPath.string() + " (renderer: " +
                goldenRenderer + ")\n  diff:   " + diffPath.string();
    return text;
}

void writeLinearPng16(const std::filesystem::path& path, const cv::Mat& linearImage, const std::string& renderer,
                      double linearPeak) {
    LIGHTSKIN_ASSERT(linearImage.depth() == CV_32F, "writeLinearPng16() needs a linear float image");
    if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
    cv::Mat encoded;
    linearImage.convertTo(encoded, CV_16U, 65535.0 / linearPeak); // saturates outside [0, peak]
    if (!cv::imwrite(path.string(), encoded)) throw Error(path.string(), std::nullopt, "could not write the PNG");
    std::ofstream sidecar(sidecarOf(path));
    sidecar << nlohmann::json{{"renderer", renderer}, {"linearPeak", linearPeak}, {"encoding", "linear * 65535 / linearPeak"}}.dump(2)
            << "\n";
    if (!sidecar) throw Error(sidecarOf(path).string(), std::nullopt, "could not write the sidecar");
}

cv::Mat readLinearPng16(const std::filesystem::path& path, std::string& renderer, double& linearPeak) {
    // Through the PNG/TIFF/JPEG guard (lightskin/core/ImageFile.h), not cv::imread: every decoder.
    if (!std::filesystem::exists(path)) throw Error(path.string(), std::nullopt, "missing or unreadable PNG");
    const cv::Mat encoded = readImageFile(path, cv::IMREAD_UNCHANGED);
    if (encoded.depth() != CV_16U) throw Error(path.string(), std::nullopt, "a golden must be a 16-bit PNG");
    std::ifstream sidecarStream(sidecarOf(path));
    if (!sidecarStream) throw Error(sidecarOf(path).string(), std::nullopt, "missing golden sidecar");
    try {
        const nlohmann::json sidecar = nlohmann::json::parse(sidecarStream);
        renderer = sidecar.at("renderer").get<std::string>();
        linearPeak = sidecar.at("linearPeak").get<double>();
    } catch (const nlohmann::json::exception& error) {
        throw Error(sidecarOf(path).string(), std::nullopt, "malformed sidecar: " + jsonErrorCause(error.what()));
    }
    if (!(linearPeak > 0.0)) throw Error(sidecarOf(path).string(), std::nullopt, "linearPeak must be positive");
    cv::Mat linear;
    encoded.convertTo(linear, CV_32F, linearPeak / 65535.0);
    return linear;
}

void writeDiffImage(const cv::Mat& actual, const cv::Mat& golden, double linearPeak,
                    const std::filesystem::path& path) {
    cv::Mat diff = cv::abs(actual - golden);
    diff.convertTo(diff, CV_8U, 255.0 * 8.0 / linearPeak); // amplified 8x for visibility
    if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
    if (!cv::imwrite(path.string(), diff)) throw Error(path.string(), std::nullopt, "could not write the diff image");
}

GoldenCandidate readGoldenCandidate(const std::filesystem::path& actualPng) {
    GoldenCandidate candidate;
    candidate.image = readLinearPng16(actualPng, candidate.renderer, candidate.linearPeak);
    const std::filesystem::path coverage = withSuffix(actualPng, ".coverage.png");
    if (std::filesystem::exists(coverage)) {
        candidate.coverage = readImageFile(coverage, cv::IMREAD_UNCHANGED);
        if (candidate.coverage.type() != CV_8UC1 || candidate.coverage.size() != candidate.image.size())
            throw Error(coverage.string(), std::nullopt, "the coverage must be an 8-bit grey PNG of the image's size");
    }
    const std::filesystem::path baseline = withSuffix(actualPng, ".baseline.png");
    if (std::filesystem::exists(baseline)) {
        std::string ignoredRenderer;
        double peak = 1.0;
        candidate.baseline = readLinearPng16(baseline, ignoredRenderer, peak);
        if (candidate.baseline.size() != candidate.image.size() || candidate.baseline.type() != candidate.image.type())
            throw Error(baseline.string(), std::nullopt, "the baseline must have the image's size and channels");
    }
    return candidate;
}

ImageError compareCandidate(const GoldenCandidate& candidate, const cv::Mat& golden) {
    ImageErrorOptions options{candidate.linearPeak, candidate.coverage, {}};
    options.regionGrid = kGoldenRegionGrid;
    if (!candidate.baseline.empty()) options.signal = golden - candidate.baseline;
    return compareImages(candidate.image, golden, options);
}

GoldenResult compareWithGolden(const cv::Mat& linearImage, const std::filesystem::path& goldenFolder,
                               const std::string& name, const GoldenThresholds& thresholds,
                               const std::filesystem::path& outputFolder, const GoldenInputs& inputs) {
    GoldenResult result;
    result.renderer = inputs.renderer;
    result.goldenPath = goldenFolder / (name + ".png");
    result.actualPath = outputFolder / (name + ".actual.png");
    writeLinearPng16(result.actualPath, linearImage, inputs.renderer, inputs.linearPeak);
    // Coverage and baseline beside the actual image (or stale ones removed), so that the promotion
    // script computes the same metrics from the files alone.
    const std::filesystem::path coveragePath = withSuffix(result.actualPath, ".coverage.png");
    const std::filesystem::path baselinePath = withSuffix(result.actualPath, ".baseline.png");
    std::filesystem::remove(coveragePath);
    std::filesystem::remove(baselinePath);
    std::filesystem::remove(withSuffix(result.actualPath, ".baseline.json"));
    if (!inputs.coverage.empty()) {
        if (inputs.coverage.type() != CV_8UC1 || inputs.coverage.size() != linearImage.size())
            throw Error(coveragePath.string(), std::nullopt, "the coverage must be CV_8UC1 of the image's size");
        if (!cv::imwrite(coveragePath.string(), inputs.coverage))
            throw Error(coveragePath.string(), std::nullopt, "could not write the coverage");
    }
    if (!inputs.baseline.empty()) writeLinearPng16(baselinePath, inputs.baseline, inputs.renderer, inputs.linearPeak);
    if (!std::filesystem::exists(result.goldenPath)) {
        result.goldenMissing = true;
        return result;
    }
    double goldenPeak = 1.0;
    const cv::Mat golden = readLinearPng16(result.goldenPath, result.goldenRenderer, goldenPeak);
    // Compare the actual image (and baseline) after the same 16-bit quantisation the golden went through.
    const GoldenCandidate candidate = readGoldenCandidate(result.actualPath);
    if (golden.size() != candidate.image.size() || golden.type() != candidate.image.type())
        throw Error(result.goldenPath.string(), std::nullopt, "golden size/type differs from the actual image");
    result.error = compareCandidate(candidate, golden);
    result.rendererMismatch = result.goldenRenderer != inputs.renderer;
    const ImageError& e = result.error;
    result.passed = !result.rendererMismatch &&
                    e.relativeMeanAbsoluteError <= thresholds.maxRelativeMeanAbsoluteError &&
                    (!thresholds.maxRelativeMse || e.relativeMse <= *thresholds.maxRelativeMse) &&
                    (!thresholds.maxMeanAbsoluteError || e.meanAbsoluteError <= *thresholds.maxMeanAbsoluteError) &&
                    (!thresholds.maxAbsoluteError || e.maxAbsoluteError <= *thresholds.maxAbsoluteError) &&
                    (!thresholds.minSsim || e.ssim >= *thresholds.minSsim) &&
                    (!thresholds.maxRegionRelativeMeanAbsoluteError ||
                     e.maxRegionRelativeMeanAbsoluteError <= *thresholds.maxRegionRelativeMeanAbsoluteError);
    if (!result.passed) {
        result.diffPath = outputFolder / (name + ".diff.png");
        writeDiffImage(candidate.image, golden, inputs.linearPeak, result.diffPath);
        std::filesystem::copy_file(result.goldenPath, outputFolder / (name + ".golden.png"),
                                   std::filesystem::copy_options::overwrite_existing);
    }
    return result;
}

} // namespace lightskin::eval
