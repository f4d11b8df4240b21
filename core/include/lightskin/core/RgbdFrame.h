#pragma once
// One RGB-D frame as every module sees it.
//
// Ownership: an RgbdFrame owns its pixels through cv::Mat's reference counting. Frame sources
// may reuse the same buffers for the next frame (no allocation per frame): a consumer that keeps
// a frame beyond the next call to FrameSource::next() must clone() it.

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>

#include <opencv2/core/mat.hpp>

#include <cstdint>
#include <optional>
#include <string>

namespace lightskin {

/// How the depth image relates to the colour image.
enum class DepthRegistration : std::uint8_t {
    /// Depth pixels are in the depth camera's own image; use depthIntrinsics and colour_T_depth.
    Unregistered,
    /// Depth was reprojected into the colour camera (hardware or software registration): depth
    /// pixel (u,v) sees the same point as colour pixel (u,v); depthIntrinsics == colourIntrinsics.
    RegisteredToColour,
};

const char* toString(DepthRegistration registration) noexcept;

struct RgbdFrame {
    /// 0-based index of the frame within its source.
    std::int64_t index = 0;

    /// Colour, CV_8UC3 in OpenCV's BGR channel order, sRGB-encoded (gamma, not linear).
    cv::Mat colour;
    /// Depth, CV_16UC1 raw sensor units along the optical axis (z, not ray length).
    /// 0 means missing. Metres = value * depthScaleMetres.
    cv::Mat depth;
    /// Metres per depth unit: 0.001 for millimetres (OpenNI, Kinect), 0.0002 for TUM (5000 = 1 m).
    double depthScaleMetres = 0.001;

    /// Capture times in seconds on the source's clock (device clock or recording timestamps).
    /// NaN when the source does not provide one.
    double colourTimestampSeconds = 0.0;
    double depthTimestampSeconds = 0.0;

    CameraIntrinsics colourIntrinsics;
    CameraIntrinsics depthIntrinsics;
    DepthRegistration registration = DepthRegistration::RegisteredToColour;
    /// Maps depth-camera coordinates to colour-camera coordinates (metres). Identity when registered.
    Pose colour_T_depth;

    /// Ground-truth pose of the colour camera in the world, when the source knows it
    /// (synthetic recordings, TUM groundtruth.txt, ICL-NUIM trajectories).
    std::optional<Pose> groundTruth_world_T_camera;

    bool hasColour() const noexcept { return !colour.empty(); }
    bool hasDepth() const noexcept { return !depth.empty(); }

    /// Depth of pixel (u,v) in metres; 0 when missing. No bounds check beyond an assertion.
    double depthMetresAt(int u, int v) const;

    /// Deep copy (pixels included).
    RgbdFrame clone() const;

    /// Checks the invariants above (types, sizes agree with intrinsics, registration consistent).
    /// Throws lightskin::Error naming `sourceName` and the frame index when one is broken.
    void validate(const std::string& sourceName) const;
};

} // namespace lightskin
