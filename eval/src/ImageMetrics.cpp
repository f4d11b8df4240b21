#include <lightskin/core/Error.h>
#include <lightskin/eval/ImageMetrics.h>

#include <opencv2/core.hpp>
#include <opencv2/quality/qualityssim.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <vector>

namespace lightskin::eval {

std::string ImageError::describe() const {
    char text[256];
    std::snprintf(
        text, sizeof text,
        "relMAE %.4f, region relMAE %.4f (%zu regions), relMSE %.3g, MAE %.3g, max %.3g, SSIM %.4f, PSNR %.2f dB over "
        "%zu px",
        relativeMeanAbsoluteError, maxRegionRelativeMeanAbsoluteError, regionsCompared, relativeMse, meanAbsoluteError,
        maxAbsoluteError, ssim, psnr, pixelsCompared);
    return text;
}

std::size_t countNonFinite(const cv::Mat& image) {
    LIGHTSKIN_ASSERT(image.depth() == CV_32F, "countNonFinite() needs a float image");
    std::size_t count = 0;
    for (int row = 0; row < image.rows; ++row) {
        const float* values = image.ptr<float>(row);
        for (int i = 0; i < image.cols * image.channels(); ++i) count += !std::isfinite(values[i]);
    }
    return count;
}

namespace {

/// A region's signal is floored at this share of what its pixels would hold at the image's mean signal.
constexpr double kRegionSignalFloor = 0.1;

/// The region metric of ImageError (maxRegionRelativeMeanAbsoluteError, regionsCompared); `sumSignal` is the whole
/// image's sum |s| over the compared pixels, error.pixelsCompared their number. Inputs validated by the caller.
void regionErrorInto(const cv::Mat& image, const cv::Mat& reference, const ImageErrorOptions& options, double sumSignal,
                     ImageError& error) {
    const bool masked = !options.mask.empty(), hasSignal = !options.signal.empty();
    const int channels = image.channels();
    int left = image.cols, top = image.rows, right = -1, bottom = -1; // bounding box of the compared pixels
    for (int row = 0; row < image.rows; ++row) {
        const std::uint8_t* m = masked ? options.mask.ptr<std::uint8_t>(row) : nullptr;
        for (int col = 0; col < image.cols; ++col) {
            if (m && m[col] == 0) continue;
            left = std::min(left, col);
            right = std::max(right, col);
            top = std::min(top, row);
            bottom = std::max(bottom, row);
        }
    }
    const int grid = options.regionGrid;
    const auto cellOf = [grid](int v, int low, int high) {
        return std::min(grid - 1, int(std::int64_t(v - low) * grid / std::int64_t(high - low + 1)));
    };
    std::vector<double> absolute(std::size_t(grid * grid), 0.0), signal(absolute.size(), 0.0);
    std::vector<std::size_t> pixels(absolute.size(), 0);
    for (int row = top; row <= bottom; ++row) {
        const float* x = image.ptr<float>(row);
        const float* r = reference.ptr<float>(row);
        const float* s = hasSignal ? options.signal.ptr<float>(row) : r;
        const std::uint8_t* m = masked ? options.mask.ptr<std::uint8_t>(row) : nullptr;
        for (int col = left; col <= right; ++col) {
            if (m && m[col] == 0) continue;
            const std::size_t cell = std::size_t(cellOf(row, top, bottom) * grid + cellOf(col, left, right));
            ++pixels[cell];
            for (int c = 0; c < channels; ++c) {
                absolute[cell] += std::abs(double(x[col * channels + c]) - double(r[col * channels + c]));
                signal[cell] += std::abs(double(s[col * channels + c]));
            }
        }
    }
    const double meanSignal = sumSignal / double(error.pixelsCompared); // per pixel, all channels
    const double share = double(error.pixelsCompared) / double(grid * grid);
    for (std::size_t cell = 0; cell < absolute.size(); ++cell) {
        if (pixels[cell] < options.minRegionPixels || double(pixels[cell]) < 0.5 * share) continue;
        ++error.regionsCompared;
        const double floor = kRegionSignalFloor * double(pixels[cell]) * meanSignal;
        const double denominator = std::max(signal[cell], floor);
        const double relative = denominator > 0.0      ? absolute[cell] / denominator
                                : absolute[cell] > 0.0 ? std::numeric_limits<double>::infinity()
                                                       : 0.0;
        error.maxRegionRelativeMeanAbsoluteError = std::max(error.maxRegionRelativeMeanAbsoluteError, relative);
    }
}

} // namespace

ImageError compareImages(const cv::Mat& image, const cv::Mat& reference, const ImageErrorOptions& options) {
    if (image.size() != reference.size() || image.type() != reference.type())
        throw Error("compareImages", std::nullopt,
                    "image " + std::to_string(image.cols) + "x" + std::to_string(image.rows) + " type " +
                        std::to_string(image.type()) + " vs reference " + std::to_string(reference.cols) + "x" +
                        std::to_string(reference.rows) + " type " + std::to_string(reference.type()));
    if (image.depth() != CV_32F) throw Error("compareImages", std::nullopt, "images must be linear float (CV_32F)");
    if (countNonFinite(image) != 0) throw Error("compareImages", std::nullopt, "the image has NaN or inf values");
    if (countNonFinite(reference) != 0) throw Error("compareImages", std::nullopt, "the reference has NaN or inf values");
    const bool masked = !options.mask.empty();
    if (masked && (options.mask.size() != image.size() || options.mask.type() != CV_8UC1))
        throw Error("compareImages", std::nullopt, "the mask must be CV_8UC1 of the image's size");
    const bool hasSignal = !options.signal.empty();
    if (hasSignal && (options.signal.size() != image.size() || options.signal.type() != image.type()))
        throw Error("compareImages", std::nullopt, "the signal must have the image's size and type");
    if (hasSignal && countNonFinite(options.signal) != 0)
        throw Error("compareImages", std::nullopt, "the signal has NaN or inf values");

    ImageError error;
    double sumSquared = 0.0, sumRelative = 0.0, sumAbsolute = 0.0, sumSignal = 0.0;
    const int channels = image.channels();
    for (int row = 0; row < image.rows; ++row) {
        const float* x = image.ptr<float>(row);
        const float* r = reference.ptr<float>(row);
        const float* signal = hasSignal ? options.signal.ptr<float>(row) : r;
        const std::uint8_t* m = masked ? options.mask.ptr<std::uint8_t>(row) : nullptr;
        for (int col = 0; col < image.cols; ++col) {
            if (m && m[col] == 0) continue;
            ++error.pixelsCompared;
            for (int c = 0; c < channels; ++c) {
                const double xv = x[col * channels + c], rv = r[col * channels + c];
                const double d = xv - rv;
                sumSquared += d * d;
                sumRelative += d * d / (rv * rv + 0.01);
                sumAbsolute += std::abs(d);
                sumSignal += std::abs(double(signal[col * channels + c]));
                error.maxAbsoluteError = std::max(error.maxAbsoluteError, std::abs(d));
            }
        }
    }
    if (sumSignal > 0.0)
        error.relativeMeanAbsoluteError = sumAbsolute / sumSignal;
    else if (sumAbsolute > 0.0)
        error.relativeMeanAbsoluteError = std::numeric_limits<double>::infinity();
    const double samples = double(error.pixelsCompared) * channels;
    if (samples > 0) {
        error.relativeMse = sumRelative / samples;
        error.meanAbsoluteError = sumAbsolute / samples;
        const double mse = sumSquared / samples;
        error.psnr = mse > 0 ? 10.0 * std::log10(options.ssimPeak * options.ssimPeak / mse)
                             : std::numeric_limits<double>::infinity();
    }
    if (options.regionGrid > 0 && error.pixelsCompared > 0)
        regionErrorInto(image, reference, options, sumSignal, error);
    cv::Mat scaledImage, scaledReference, qualityMap;
    image.convertTo(scaledImage, CV_32F, 255.0 / options.ssimPeak);
    reference.convertTo(scaledReference, CV_32F, 255.0 / options.ssimPeak);
    const cv::Scalar ssim = cv::quality::QualitySSIM::compute(scaledReference, scaledImage, qualityMap);
    double ssimSum = 0.0;
    for (int c = 0; c < channels; ++c) ssimSum += ssim[c];
    error.ssim = ssimSum / channels;
    return error;
}

} // namespace lightskin::eval
