#include <lightskin/bench/Flicker.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace lightskin::bench {

namespace {

/// The mean of the channels of `image` where `world` is seen (FlickerSeries::addFrame), else NaN.
float sampleAt(const glm::dvec3& world, const Pose& camera_T_world, const CameraIntrinsics& k, const cv::Mat& coverage,
               const cv::Mat& virtualDepth, const cv::Mat& image) {
    const glm::dvec3 c = camera_T_world.transformPoint(world);
    if (c.z <= 0.05) return std::nanf("");
    const glm::dvec2 px = k.project(c);
    const int u = int(std::floor(px.x)), v = int(std::floor(px.y));
    if (u < 0 || v < 0 || u >= image.cols || v >= image.rows || !coverage.at<std::uint8_t>(v, u) ||
        std::abs(double(virtualDepth.at<float>(v, u)) - c.z) >= 0.01 + 0.01 * c.z)
        return std::nanf("");
    const cv::Vec3f x = image.at<cv::Vec3f>(v, u);
    return (x[0] + x[1] + x[2]) / 3.0f;
}

} // namespace

void FlickerSeries::addFrame(const std::vector<glm::dvec3>& worldPoints, const CameraIntrinsics& k,
                             const Pose& world_T_camera, const cv::Mat& coverage, const cv::Mat& virtualDepth,
                             const cv::Mat& lightSkin, const cv::Mat& bruteForce) {
    const Pose camera_T_world = world_T_camera.inverse();
    for (std::size_t p = 0; p < points_; ++p) {
        const bool have = p < worldPoints.size();
        lightSkin_.push_back(have ? sampleAt(worldPoints[p], camera_T_world, k, coverage, virtualDepth, lightSkin)
                                  : std::nanf(""));
        bruteForce_.push_back(have ? sampleAt(worldPoints[p], camera_T_world, k, coverage, virtualDepth, bruteForce)
                                   : std::nanf(""));
    }
}

double FlickerSeries::bruteForceLevel() const {
    double sum = 0.0;
    std::size_t count = 0;
    for (float v : bruteForce_)
        if (!std::isnan(v)) {
            sum += double(v);
            ++count;
        }
    return count ? sum / double(count) : 1.0;
}

FlickerSeries::Result FlickerSeries::measure(int firstFrame, int endFrame) const {
    const double level = bruteForceLevel();
    double sumLs = 0.0, sumBf = 0.0, sumExcess = 0.0;
    Result r;
    for (int f = std::max(1, firstFrame); f < std::min(endFrame, frames()); ++f)
        for (std::size_t p = 0; p < points_; ++p) {
            const std::size_t i0 = std::size_t(f - 1) * points_ + p, i1 = i0 + points_;
            if (std::isnan(lightSkin_[i0]) || std::isnan(lightSkin_[i1]) || std::isnan(bruteForce_[i0]) ||
                std::isnan(bruteForce_[i1]))
                continue;
            const double ls = double(lightSkin_[i1]) - double(lightSkin_[i0]);
            const double bf = double(bruteForce_[i1]) - double(bruteForce_[i0]);
            sumLs += ls * ls;
            sumBf += bf * bf;
            sumExcess += (ls - bf) * (ls - bf);
            ++r.samples;
        }
    if (r.samples == 0) return r;
    const double n = double(r.samples);
    r.lightSkin = std::sqrt(sumLs / n) / level;
    r.bruteForce = std::sqrt(sumBf / n) / level;
    r.excess = std::sqrt(sumExcess / n) / level;
    return r;
}

double FlickerSeries::excessWithoutWorst(double fraction) const {
    const double level = bruteForceLevel();
    struct PointSums {
        double squares = 0.0;
        std::size_t samples = 0;
    };
    std::vector<PointSums> sums(points_);
    for (int f = 1; f < frames(); ++f)
        for (std::size_t p = 0; p < points_; ++p) {
            const std::size_t i0 = std::size_t(f - 1) * points_ + p, i1 = i0 + points_;
            const double d =
                (double(lightSkin_[i1]) - double(lightSkin_[i0])) - (double(bruteForce_[i1]) - double(bruteForce_[i0]));
            if (std::isnan(d)) continue;
            sums[p].squares += d * d;
            ++sums[p].samples;
        }
    std::erase_if(sums, [](const PointSums& s) { return s.samples == 0; });
    std::sort(sums.begin(), sums.end(), [](const PointSums& a, const PointSums& b) {
        return a.squares / double(a.samples) < b.squares / double(b.samples);
    });
    sums.resize(sums.size() - std::size_t(fraction * double(sums.size())));
    double squares = 0.0;
    std::size_t samples = 0;
    for (const PointSums& s : sums) {
        squares += s.squares;
        samples += s.samples;
    }
    return samples ? std::sqrt(squares / double(samples)) / level : 0.0;
}

} // namespace lightskin::bench
