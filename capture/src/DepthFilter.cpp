#include "BilateralDepthKernel.h"

#include <lightskin/capture/DepthFilter.h>
#include <lightskin/core/Error.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace lightskin::capture {

BilateralDepthFilter::BilateralDepthFilter(const BilateralDepthFilterParams& params)
    : params_(params) {
    LIGHTSKIN_ASSERT(params.kernelSize >= 1 && params.kernelSize % 2 == 1, "kernelSize must be odd and positive");
    LIGHTSKIN_ASSERT(params.sigmaSpacePixels > 0.0 && params.sigmaDepthMetres > 0.0, "sigmas must be positive");
    LIGHTSKIN_ASSERT(params.minDepthMetres >= 0.0 && params.maxDepthMetres > params.minDepthMetres,
                     "depth range must satisfy 0 <= min < max");
}

void BilateralDepthFilter::filterInto(const cv::Mat& depth, double depthScaleMetres, cv::Mat& outMetres) {
    LIGHTSKIN_ASSERT(depth.type() == CV_16UC1 || depth.type() == CV_32FC1, "depth must be CV_16UC1 or CV_32FC1");
    LIGHTSKIN_ASSERT(depthScaleMetres > 0.0, "depth scale must be positive");
    LIGHTSKIN_ASSERT(outMetres.data == nullptr || outMetres.data != depth.data, "filterInto cannot work in place");
    if (params_.implementation == BilateralImplementation::OpenCv)
        filterOpenCv(depth, depthScaleMetres, outMetres);
    else
        filterSimd(depth, depthScaleMetres, outMetres);
}

void BilateralDepthFilter::filterSimd(const cv::Mat& depth, double depthScaleMetres, cv::Mat& outMetres) {
    const int radius = std::max(params_.kernelSize / 2, 1); // as cv::bilateralFilter
    const auto r = std::size_t(radius);
    const auto width = std::size_t(depth.cols), height = std::size_t(depth.rows);
    const std::size_t stride = width + 2 * r + detail::kMaxBilateralLanes; // the row tail's vector
    // far beyond any depth: its range weight underflows to exactly 0 (BilateralDepthKernel.h)
    constexpr float kSentinel = 1e18f;
    if (stride != paddedStride_ || padded_.size() != stride * (height + 2 * r)) {
        paddedStride_ = stride;
        padded_.assign(stride * (height + 2 * r), kSentinel);
        // OpenCV's taps (bilateral_filter.dispatch.cpp): r' = |(i, j)| <= radius, centre apart
        tapOffsets_.clear();
        tapLog2Space_.clear();
        const double coefficient = -0.5 / (params_.sigmaSpacePixels * params_.sigmaSpacePixels);
        for (int i = -radius; i <= radius; ++i)
            for (int j = -radius; j <= radius; ++j) {
                const double distance = std::sqrt(double(i * i + j * j));
                if (distance > double(radius) || (i == 0 && j == 0)) continue;
                tapOffsets_.push_back(std::ptrdiff_t(i) * std::ptrdiff_t(stride) + j);
                tapLog2Space_.push_back(float(distance * distance * coefficient / std::log(2.0)));
            }
    }
    outMetres.create(depth.size(), CV_32FC1);
    // Valid = positive, finite and inside the optional range clamp (as the OpenCv path's inRange);
    // NaN fails every comparison. Metres as convertTo(CV_32F, scale) computes them.
    const float low = std::max(float(params_.minDepthMetres), std::numeric_limits<float>::min());
    const float high =
        std::isfinite(params_.maxDepthMetres) ? float(params_.maxDepthMetres) : std::numeric_limits<float>::max();
    const auto scale = float(depthScaleMetres);
    for (std::size_t v = 0; v < height; ++v) {
        float* row = &padded_[(v + r) * stride + r];
        const auto vi = int(v);
        if (depth.type() == CV_16UC1) {
            const std::uint16_t* in = depth.ptr<std::uint16_t>(vi);
            for (std::size_t u = 0; u < width; ++u) {
                const float z = float(in[u]) * scale;
                row[u] = z >= low && z <= high ? z : kSentinel;
            }
        } else {
            const float* in = depth.ptr<float>(vi);
            for (std::size_t u = 0; u < width; ++u) {
                const float z = in[u] * scale;
                row[u] = z >= low && z <= high ? z : kSentinel;
            }
        }
        for (std::size_t k = 1; k <= r; ++k) row[-std::ptrdiff_t(k)] = row[0], row[width - 1 + k] = row[width - 1];
    }
    for (std::size_t k = 0; k < r; ++k) { // replicated top and bottom rows
        std::copy_n(&padded_[r * stride], stride, &padded_[k * stride]);
        std::copy_n(&padded_[(height + r - 1) * stride], stride, &padded_[(height + r + k) * stride]);
    }
    // c^2 = log2(e) / (2 sigma_depth^2): 2^(-(c dz)^2) = exp(-dz^2 / 2 sigma_depth^2)
    const auto rangeScale = float(std::sqrt(1.0 / (2.0 * std::log(2.0))) / params_.sigmaDepthMetres);
    const detail::BilateralTaps taps{tapOffsets_.data(), tapLog2Space_.data(), tapOffsets_.size()};
    detail::bilateralRows(&padded_[r * stride + r], stride, height, width, taps, rangeScale, outMetres.ptr<float>(),
                          outMetres.step1());
}

void BilateralDepthFilter::filterOpenCv(const cv::Mat& depth, double depthScaleMetres, cv::Mat& outMetres) {
    depth.convertTo(metres_, CV_32F, depthScaleMetres);

    // Valid = positive, finite and inside the optional range clamp. NaN fails every comparison.
    const float low = std::max(float(params_.minDepthMetres), std::numeric_limits<float>::min());
    const float high =
        std::isfinite(params_.maxDepthMetres) ? float(params_.maxDepthMetres) : std::numeric_limits<float>::max();
    cv::inRange(metres_, cv::Scalar(double(low)), cv::Scalar(double(high)), valid_);
    cv::bitwise_not(valid_, invalid_);
    outMetres.create(depth.size(), CV_32FC1);
    double deepest = 0.0;
    cv::minMaxLoc(metres_, nullptr, &deepest, nullptr, nullptr, valid_);
    if (cv::countNonZero(valid_) == 0) {
        outMetres.setTo(0.0f);
        return;
    }
    // Holes become a depth so far behind everything that their range weight is exactly 0.
    const double sentinel = deepest + 15.0 * params_.sigmaDepthMetres;
    metres_.setTo(cv::Scalar(sentinel), invalid_);
    cv::bilateralFilter(metres_, outMetres, params_.kernelSize, params_.sigmaDepthMetres, params_.sigmaSpacePixels,
                        cv::BORDER_REPLICATE);
    outMetres.setTo(0.0f, invalid_);
}

cv::Mat BilateralDepthFilter::filter(const cv::Mat& depth, double depthScaleMetres) {
    cv::Mat out;
    filterInto(depth, depthScaleMetres, out);
    return out;
}

} // namespace lightskin::capture
