#pragma once
// Flicker of the indirect light at tracked surface points, LightSkin against the brute force on the same VALs
// (`lightskin bench-realdepth`, lightskin_bench_motion; docs/BENCHMARKS.md "Flicker").
//
// A tracked point is a surface point followed from frame to frame (a mesh vertex; for moving content it moves
// with its object). Per frame each technique's indirect light is sampled at the points the camera sees; flicker is
// the RMS over (point, consecutive frame pair) of the change of that light (mean of the channels), divided by the
// brute force's mean level over every sample. The excess flicker of LightSkin subtracts, per sample, the brute
// force's own change: what LightSkin adds to the change the light itself undergoes (camera, objects or lights
// moving, depth noise).

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>

#include <glm/vec3.hpp>
#include <opencv2/core/mat.hpp>

#include <cstddef>
#include <vector>

namespace lightskin::bench {

class FlickerSeries {
public:
    /// `points` tracked points per frame, in the same order every frame.
    explicit FlickerSeries(std::size_t points)
        : points_(points) {}

    /// Appends one frame: each world point (world_T_camera's camera, `k`'s image) is sampled in both images
    /// (CV_32FC3 linear light) where `coverage` (CV_8UC1) marks virtual content and the virtual depth (CV_32FC1,
    /// metres along z) is within 1 cm + 1 % of the point's (visible, not hidden by other content); NaN elsewhere.
    void addFrame(const std::vector<glm::dvec3>& worldPoints, const CameraIntrinsics& k, const Pose& world_T_camera,
                  const cv::Mat& coverage, const cv::Mat& virtualDepth, const cv::Mat& lightSkin,
                  const cv::Mat& bruteForce);

    struct Result {
        double bruteForce = 0.0, lightSkin = 0.0, excess = 0.0; ///< flicker, fractions of the brute force's level
        std::size_t samples = 0;                                ///< (point, frame pair) samples seen in both frames
    };
    /// Over every frame pair, or over the pairs (f - 1, f) with f in [firstFrame, endFrame).
    Result measure() const { return measure(1, frames()); }
    Result measure(int firstFrame, int endFrame) const;
    /// LightSkin's excess flicker without the `fraction` of tracked points whose own excess is largest: whether the
    /// excess is everywhere or concentrated at a few points.
    double excessWithoutWorst(double fraction) const;
    int frames() const noexcept { return points_ ? int(lightSkin_.size() / points_) : 0; }

    const std::vector<float>& lightSkinSeries() const noexcept { return lightSkin_; }
    const std::vector<float>& bruteForceSeries() const noexcept { return bruteForce_; }

private:
    double bruteForceLevel() const; ///< mean of every brute-force sample (1 when there is none)

    std::size_t points_;
    std::vector<float> lightSkin_, bruteForce_; // frame-major: [frame * points + point]
};

} // namespace lightskin::bench
