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

void smoothSurfaceMaskInto(const cv::Mat& coverage, const cv::Mat& normals, const cv::Mat& depth,
                           double maxNormalAngleDegrees, double maxRelativeDepthStep, cv::Mat& mask,
                           const cv::Mat& normalSensitivity) {
    if (coverage.type() != CV_8UC1 || normals.type() != CV_32FC3 || depth.type() != CV_32FC1 ||
        normals.size() != coverage.size() || depth.size() != coverage.size())
        throw Error("smoothSurfaceMaskInto", std::nullopt,
                    "expected CV_8UC1 coverage, CV_32FC3 normals, CV_32FC1 depth of one size");
    const bool sensitive = !normalSensitivity.empty();
    if (sensitive && (normalSensitivity.type() != CV_32FC1 || normalSensitivity.size() != coverage.size()))
        throw Error("smoothSurfaceMaskInto", std::nullopt,
                    "expected a CV_32FC1 normal sensitivity of the coverage's size");
    const double minCos = std::cos(maxNormalAngleDegrees * 3.14159265358979323846 / 180.0);
    mask.create(coverage.size(), CV_8UC1);
    mask.setTo(cv::Scalar(0));
    for (int v = 2; v + 2 < coverage.rows; ++v)
        for (int u = 2; u + 2 < coverage.cols; ++u) {
            if (!coverage.at<std::uint8_t>(v, u)) continue;
            const cv::Vec3f n = normals.at<cv::Vec3f>(v, u);
            const double z = double(depth.at<float>(v, u));
            bool smooth = std::isfinite(z) && z > 0.0;
            cv::Vec3d meanNormal(0.0, 0.0, 0.0); // of the window's unit normals (the sensitivity test)
            for (int dv = -2; dv <= 2 && smooth; ++dv)
                for (int du = -2; du <= 2 && smooth; ++du) {
                    const cv::Vec3f m = normals.at<cv::Vec3f>(v + dv, u + du);
                    smooth = coverage.at<std::uint8_t>(v + dv, u + du) &&
                             double(n.dot(m)) >= minCos * double(cv::norm(n)) * double(cv::norm(m)) &&
                             std::abs(double(depth.at<float>(v + dv, u + du)) - z) <= maxRelativeDepthStep * z;
                    if (smooth && sensitive) meanNormal += cv::Vec3d(m) / cv::norm(m);
                }
            if (smooth && sensitive) {
                // S times the angle between the pixel's normal and its window's mean normal (header):
                // atan2 of |n x mean| and n . mean, exactly 0 where every normal is equal.
                const double s = double(normalSensitivity.at<float>(v, u));
                const cv::Vec3d centre(n);
                const double angle = std::atan2(cv::norm(centre.cross(meanNormal)), centre.dot(meanNormal));
                smooth = !std::isnan(s) && (angle == 0.0 || s * angle <= 0.5);
            }
            if (smooth) mask.at<std::uint8_t>(v, u) = 255;
        }
}

namespace {

/// |value - reference| within half the floored reference: the measure's one tolerance.
bool near(double value, double reference, double floor) {
    return std::abs(value - reference) <= 0.5 * std::max(reference, floor);
}

/// Whether the pixel lies on a smooth profile (Speckle.h): along one of the four directions e it is
/// on the straight lines through its +-1 and its +-2 neighbours, and across e it is not an extremum
/// of its two +-1 neighbours. The caller guarantees a covered 5x5 window. A direction that would use a
/// back-face pixel (`backFacing`, may be empty) explains nothing: the dark inside is no profile.
bool onSmoothProfile(const cv::Mat& y, int u, int v, double floor, const cv::Mat& backFacing) {
    const auto at = [&](int du, int dv) { return double(y.at<float>(v + dv, u + du)); };
    const auto back = [&](int du, int dv) {
        return !backFacing.empty() && backFacing.at<std::uint8_t>(v + dv, u + du) != 0;
    };
    const double value = at(0, 0);
    static constexpr int kDirections[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
    for (const auto& e : kDirections) {
        const int du = e[0], dv = e[1];
        if (back(-du, -dv) || back(du, dv) || back(-2 * du, -2 * dv) || back(2 * du, 2 * dv) || back(dv, -du) ||
            back(-dv, du))
            continue;
        const double line1 = 0.5 * (at(-du, -dv) + at(du, dv)),
                     line2 = 0.5 * (at(-2 * du, -2 * dv) + at(2 * du, 2 * dv));
        if (!near(value, line1, floor) || !near(value, line2, floor)) continue;
        const double a = at(dv, -du), b = at(-dv, du); // the +-1 neighbours across e
        const double lo = std::min(a, b), hi = std::max(a, b);
        if (value >= lo - 0.5 * std::max(lo, floor) && value <= hi + 0.5 * std::max(hi, floor)) return true;
    }
    return false;
}

} // namespace

SpeckleStats measureSpeckle(const cv::Mat& linearBgr, const cv::Mat& coverage, cv::Mat* map, const cv::Mat& smooth,
                            bool smoothProfiles, const cv::Mat& backFacing) {
    if (linearBgr.type() != CV_32FC3 || coverage.type() != CV_8UC1 || linearBgr.size() != coverage.size())
        throw Error("measureSpeckle", std::nullopt,
                    "expected a CV_32FC3 image and a CV_8UC1 coverage mask of the same size");
    SpeckleStats s;
    cv::Mat y, interior, median;
    luminanceInto(linearBgr, y);
    // Erode with a 5x5 square and zero outside the image: an interior pixel's neighbourhood is all covered.
    cv::erode(coverage != 0, interior, cv::Mat::ones(5, 5, CV_8U), cv::Point(-1, -1), 1, cv::BORDER_CONSTANT,
              cv::Scalar(0));
    if (!smooth.empty()) {
        if (smooth.type() != CV_8UC1 || smooth.size() != coverage.size())
            throw Error("measureSpeckle", std::nullopt, "the smooth mask must be CV_8UC1 of the image's size");
        interior.setTo(cv::Scalar(0), smooth == 0);
    }
    if (!backFacing.empty()) {
        if (backFacing.type() != CV_8UC1 || backFacing.size() != coverage.size())
            throw Error("measureSpeckle", std::nullopt, "the back-face mask must be CV_8UC1 of the image's size");
        interior.setTo(cv::Scalar(0), backFacing != 0);
    }
    // Non-finite values would poison the median filter: replace them by 0 for the median only
    // (a non-finite pixel is counted as blown below).
    cv::Mat finiteY = y.clone();
    cv::patchNaNs(finiteY, 0.0);
    cv::max(cv::min(finiteY, 3.0e38), -3.0e38, finiteY);
    cv::medianBlur(finiteY, median, 5);
    if (!backFacing.empty()) // windows with a back face: the median of their front-face pixels (Speckle.h)
        for (int v = 2; v + 2 < y.rows; ++v)
            for (int u = 2; u + 2 < y.cols; ++u) {
                if (!interior.at<std::uint8_t>(v, u)) continue;
                float front[25];
                int count = 0;
                for (int dv = -2; dv <= 2; ++dv)
                    for (int du = -2; du <= 2; ++du)
                        if (!backFacing.at<std::uint8_t>(v + dv, u + du))
                            front[count++] = finiteY.at<float>(v + dv, u + du);
                if (count == 25) continue;                                 // medianBlur's value
                std::nth_element(front, front + count / 2, front + count); // count >= 1: the pixel itself
                median.at<float>(v, u) = front[count / 2];
            }

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
    const double floor = 0.1 * s.meanLuminance, litLevel = 0.1 * s.meanLuminance;
    if (map) {
        map->create(y.size(), CV_8UC1);
        map->setTo(cv::Scalar(0));
        map->setTo(cv::Scalar(64), interior);
    }
    for (int v = 0; v < y.rows; ++v)
        for (int u = 0; u < y.cols; ++u) {
            if (!interior.at<std::uint8_t>(v, u)) continue;
            const double value = double(y.at<float>(v, u)), m = double(median.at<float>(v, u));
            const auto mark = [&] {
                if (map) map->at<std::uint8_t>(v, u) = 255;
            };
            if (!std::isfinite(value)) {
                mark();
                ++s.specklePixels;
                ++s.blownPixels;
                continue;
            }
            const double scale = std::max(m, floor);
            if (std::abs(value - m) <= 0.5 * scale) continue;
            if (smoothProfiles && onSmoothProfile(finiteY, u, v, floor, backFacing)) continue;
            mark();
            ++s.specklePixels;
            if (m >= litLevel && value < 0.1 * m) ++s.blackPixels;
            if (value > 10.0 * scale) ++s.blownPixels;
        }
    return s;
}

} // namespace lightskin::eval
