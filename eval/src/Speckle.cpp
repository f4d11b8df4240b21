#include <lightskin/core/Error.h>
#include <lightskin/eval/Speckle.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace lightskin::eval {

std::string SpeckleStats::describe() const {
    char text[200];
    std::snprintf(text, sizeof text, "speckle %.3f %% (%zu of %zu interior pixels; %zu black, %zu blown), mean Y %.4g",
                  100.0 * speckleFraction(), specklePixels, interiorPixels, blackPixels, blownPixels, meanLuminance);
    return text;
}

void luminanceInto(const cv::Mat& linearBgr, cv::Mat& luminance) {
    if (linearBgr.type() != CV_32FC3) throw Error("luminanceInto", std::nullopt, "expected a CV_32FC3 image");
    // BGR order: weights of B, G, R (Rec. 709 / sRGB primaries).
    const cv::Matx13f weights(0.0722f, 0.7152f, 0.2126f);
    cv::transform(linearBgr, luminance, weights);
}

SpeckleStats measureSpeckle(const cv::Mat& linearBgr, const cv::Mat& coverage) {
    if (linearBgr.type() != CV_32FC3 || coverage.type() != CV_8UC1 || linearBgr.size() != coverage.size())
        throw Error("measureSpeckle", std::nullopt,
                    "expected a CV_32FC3 image and a CV_8UC1 coverage mask of the same size");
    SpeckleStats s;
    cv::Mat y, interior, median;
    luminanceInto(linearBgr, y);
    // Erode with a 5x5 square and zero outside the image: an interior pixel's neighbourhood is all covered.
    cv::erode(coverage != 0, interior, cv::Mat::ones(5, 5, CV_8U), cv::Point(-1, -1), 1, cv::BORDER_CONSTANT,
              cv::Scalar(0));
    // Non-finite values would poison the median filter: replace them by 0 for the median only
    // (a non-finite pixel is counted as blown below).
    cv::Mat finiteY = y.clone();
    cv::patchNaNs(finiteY, 0.0);
    cv::max(cv::min(finiteY, 3.0e38), -3.0e38, finiteY);
    cv::medianBlur(finiteY, median, 5);

    double sum = 0.0;
    std::size_t finiteCount = 0;
    for (int v = 0; v < y.rows; ++v)
        for (int u = 0; u < y.cols; ++u)
            if (interior.at<std::uint8_t>(v, u)) {
                ++s.interiorPixels;
                const float value = y.at<float>(v, u);
                if (std::isfinite(value)) {
                    sum += double(value);
                    ++finiteCount;
                }
            }
    s.meanLuminance = finiteCount ? sum / double(finiteCount) : 0.0;
    const double floor = 0.01 * s.meanLuminance, litLevel = 0.1 * s.meanLuminance;
    for (int v = 0; v < y.rows; ++v)
        for (int u = 0; u < y.cols; ++u) {
            if (!interior.at<std::uint8_t>(v, u)) continue;
            const double value = double(y.at<float>(v, u)), m = double(median.at<float>(v, u));
            if (!std::isfinite(value)) {
                ++s.specklePixels;
                ++s.blownPixels;
                continue;
            }
            const double scale = std::max(m, floor);
            if (std::abs(value - m) <= 0.5 * scale) continue;
            ++s.specklePixels;
            if (m >= litLevel && value < 0.1 * m) ++s.blackPixels;
            if (value > 10.0 * scale) ++s.blownPixels;
        }
    return s;
}

} // namespace lightskin::eval
