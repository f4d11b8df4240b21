#include <lightskin/core/Error.h>
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
} // namespace

std::string GoldenResult::describe() const {
    if (goldenMissing) return "golden missing: " + goldenPath.string() + " (actual written to " + actualPath.string() + ")";
    std::string text = (passed ? "passed: " : "FAILED: ") + error.describe();
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
    const cv::Mat encoded = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
    if (encoded.empty()) throw Error(path.string(), std::nullopt, "missing or unreadable PNG");
    if (encoded.depth() != CV_16U) throw Error(path.string(), std::nullopt, "a golden must be a 16-bit PNG");
    std::ifstream sidecarStream(sidecarOf(path));
    if (!sidecarStream) throw Error(sidecarOf(path).string(), std::nullopt, "missing golden sidecar");
    try {
        const nlohmann::json sidecar = nlohmann::json::parse(sidecarStream);
        renderer = sidecar.at("renderer").get<std::string>();
        linearPeak = sidecar.at("linearPeak").get<double>();
    } catch (const nlohmann::json::exception& error) {
        throw Error(sidecarOf(path).string(), std::nullopt, std::string("malformed sidecar: ") + error.what());
    }
    if (!(linearPeak > 0.0)) throw Error(sidecarOf(path).string(), std::nullopt, "linearPeak must be positive");
    cv::Mat linear;
    encoded.convertTo(linear, CV_32F, linearPeak / 65535.0);
    return linear;
}

GoldenResult compareWithGolden(const cv::Mat& linearImage, const std::filesystem::path& goldenFolder,
                               const std::string& name, const GoldenThresholds& thresholds,
                               const std::filesystem::path& outputFolder, const std::string& renderer,
                               double linearPeak) {
    GoldenResult result;
    result.goldenPath = goldenFolder / (name + ".png");
    result.actualPath = outputFolder / (name + ".actual.png");
    writeLinearPng16(result.actualPath, linearImage, renderer, linearPeak);
    if (!std::filesystem::exists(result.goldenPath)) {
        result.goldenMissing = true;
        return result;
    }
    double goldenPeak = 1.0;
    const cv::Mat golden = readLinearPng16(result.goldenPath, result.goldenRenderer, goldenPeak);
    // Compare the actual image after the same 16-bit quantisation the golden went through.
    std::string ignoredRenderer;
    double ignoredPeak = 1.0;
    const cv::Mat actual = readLinearPng16(result.actualPath, ignoredRenderer, ignoredPeak);
    if (golden.size() != actual.size() || golden.type() != actual.type())
        throw Error(result.goldenPath.string(), std::nullopt, "golden size/type differs from the actual image");
    result.error = compareImages(actual, golden, ImageErrorOptions{linearPeak, {}});
    result.passed = result.error.relativeMse <= thresholds.maxRelativeMse &&
                    result.error.meanAbsoluteError <= thresholds.maxMeanAbsoluteError &&
                    result.error.maxAbsoluteError <= thresholds.maxAbsoluteError && result.error.ssim >= thresholds.minSsim;
    if (!result.passed) {
        result.diffPath = outputFolder / (name + ".diff.png");
        cv::Mat diff = cv::abs(actual - golden);
        diff.convertTo(diff, CV_8U, 255.0 * 8.0 / linearPeak); // amplified 8x for visibility
        cv::imwrite(result.diffPath.string(), diff);
        std::filesystem::copy_file(result.goldenPath, outputFolder / (name + ".golden.png"),
                                   std::filesystem::copy_options::overwrite_existing);
    }
    return result;
}

} // namespace lightskin::eval
