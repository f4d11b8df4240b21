#include <lightskin/core/Error.h>
#include <lightskin/eval/ImageMetrics.h>

#include <opencv2/core.hpp>
#include <opencv2/quality/qualityssim.hpp>

#include <cmath>
#include <cstdio>
#include <limits>

namespace lightskin::eval {

std::string ImageError::describe() const {
    char text[256];
    std::snprintf(
        text, sizeof text, "relMAE %.4f, relMSE %.3g, MAE %.3g, max %.3g, SSIM %.4f, PSNR %.2f dB over %zu px",
        relativeMeanAbsoluteError, relativeMse, meanAbsoluteError, maxAbsoluteError, ssim, psnr, pixelsCompared);
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
