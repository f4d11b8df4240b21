#pragma once
// Synthetic camera images of a TagWorld with exact ground truth (tests, benchmarks, demos).
// Each tag is the family's real bitmap (renderTagBitmap) mapped by the exact plane-to-image
// homography of an ideal pinhole camera (no distortion), rendered supersampled and box-filtered,
// then optionally blurred along a line (motion blur) and given Gaussian noise.

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>
#include <lightskin/tracking/TagWorld.h>

#include <opencv2/core/mat.hpp>

#include <cstdint>

namespace lightskin::tracking {

struct SyntheticTagImageSettings {
    /// Samples per pixel along each axis (box filter). 4 gives edges good to ~0.02 px.
    int supersampling = 4;
    /// Grey levels of the background and of the tag's black and white cells.
    std::uint8_t background = 128;
    /// Optional background picture (CV_8UC1, the output size) drawn instead of the uniform grey,
    /// e.g. clutter for benchmarks. Not owned beyond the call.
    cv::Mat backgroundImage;
    std::uint8_t black = 25;
    std::uint8_t white = 230;
    /// Length of a linear motion blur in pixels (0 = none) and its direction (degrees from +x).
    double motionBlurPx = 0.0;
    double motionBlurAngleDegrees = 0.0;
    /// Standard deviation of additive Gaussian noise, grey levels (0 = none), and its seed.
    double noiseSigma = 0.0;
    std::uint64_t noiseSeed = 1;
};

/// Renders every tag of `world` seen from `world_T_camera` (camera x right, y down, z forward)
/// into a CV_8UC1 image of intrinsics.width x intrinsics.height; distortion is ignored. Tags any of
/// whose corners lie less than 1 cm in front of the camera are left out (no wrap-around).
cv::Mat renderSyntheticTagImage(const TagWorld& world, const CameraIntrinsics& intrinsics, const Pose& world_T_camera,
                                const SyntheticTagImageSettings& settings = {});

/// A camera at `eye` looking at `target` (world frame), image "up" (-y of the camera) as close to
/// `up` as possible: world_T_camera.
Pose lookAt(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up);

} // namespace lightskin::tracking
