#include <lightskin/capture/DepthFilter.h>
#include <lightskin/core/Error.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

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
