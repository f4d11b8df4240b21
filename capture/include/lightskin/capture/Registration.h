#pragma once
// Software depth-to-colour registration: reprojects a depth image taken by the depth (IR) camera
// into the colour camera, for sources whose depth is not registered by the device (.oni files
// recorded without registration, fakenect dumps, libfreenect's raw disparity mode, OpenNI2
// devices that cannot register, recordings stored unregistered).
//
//   auto registrar = capture::DepthRegistrar::create(calibration);    // once: allocates its tables
//   registrar.registerInto(rawDepth, frame.depthScaleMetres, registered); // per frame: no allocation
//
// Every valid depth pixel (u,v) at z is back-projected with the depth intrinsics (distortion
// undone), moved into the colour camera with colour_T_depth, projected with the colour intrinsics
// (distortion applied) and written to the nearest colour pixel. Collisions keep the nearest depth
// (z-buffer: the surface the colour camera sees). Colour pixels that no depth pixel reaches stay 0
// (holes stay holes: nothing is interpolated), including the real scene's occlusion shadows.
// Where the colour camera samples the surface more densely than the depth camera (a colour focal
// length above the depth one, or surfaces seen at a grazing angle by the depth camera only) the
// splatting leaves cracks of single pixels; for a Kinect v1 (colour f 525 < depth f 576) it does not.
//
// Why not cv::rgbd::registerDepth (OpenCV contrib 4.6, Debian 12), which computes the same thing:
// on the .oni's frames both give the same 194,062 valid pixels, all within 1 mm of each other, but
// it assigns a new output matrix on every call (a 600 KB allocation per VGA frame, even into a
// preallocated buffer; the per-frame code here must not allocate), ignores the depth camera's
// distortion, and is not faster: 2.76 ms against 2.39 ms CPU time per 640x480 frame, measured side
// by side (docs/BENCHMARKS.md, "Capture: depth-to-colour registration", capture/bench/RegistrationBenchmark.cpp).
//
// Units: depth in raw sensor units on both sides (metres = value * depthScaleMetres); the
// registered value is the depth along the colour camera's optical axis.

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>

#include <opencv2/core/mat.hpp>

#include <string>
#include <vector>

namespace lightskin::capture {

/// The depth camera, the colour camera and the rigid transform between them.
struct RegistrationCalibration {
    CameraIntrinsics depth;  ///< the depth (IR) camera's own image; its distortion is undone
    CameraIntrinsics colour; ///< the colour camera; the registered image has its size; distortion applied
    Pose colour_T_depth;     ///< depth-camera coordinates -> colour-camera coordinates, metres
    /// Where the numbers come from, for reports and `lightskin info` (e.g. "recording header",
    /// "stream field of view + Kinect v1 defaults (NYU Depth V2)").
    std::string source;
};

/// Kinect v1 (PrimeSense PS1080) default extrinsic when a device or file has none: the translation
/// of the NYU Depth V2 toolbox's calibration (camera_params.m, RGBDemo, libfreenect dumps),
/// t = (0.0250319, 0.00066239, -0.00029342) m, depth-camera origin in colour-camera coordinates,
/// and no rotation (NYU's is within 0.4 degrees of identity; not used, its sign convention is
/// unverified here). Checked on tests/data/oni-kinect-v1: the colour image's mean gradient at the
/// registered depth edges peaks at t_x = +0.025..+0.030 m (65.7-75.4) and is 51.0 at -0.025 m
/// (docs/BENCHMARKS.md, "Capture: depth-to-colour registration"). Each unit differs by a few pixels.
Pose kinectV1DefaultColour_T_depth();
/// The depth camera's default intrinsics when a Kinect v1 reports none: 640x480, f 575.8157,
/// centre 319.5/239.5 (ROS openni_camera's default depth focal length).
CameraIntrinsics kinectV1DefaultDepthIntrinsics();

class DepthRegistrar {
public:
    /// Precomputes the undistorted ray of every depth pixel. Throws lightskin::Error (naming
    /// calibration.source) when either intrinsics is invalid.
    static DepthRegistrar create(const RegistrationCalibration& calibration);

    /// Registers `depth` (CV_16UC1 of the depth intrinsics' size, raw units, 0 = missing) into
    /// `registered` (CV_16UC1 of the colour intrinsics' size, same units; created once and reused).
    /// `depthScaleMetres` > 0 converts units to metres for the transform. Asserts on a wrong size or
    /// type (the source checked them). Registered values are rounded to the nearest unit and
    /// clamped to [1, 65535]; points behind the colour camera are dropped.
    void registerInto(const cv::Mat& depth, double depthScaleMetres, cv::Mat& registered) const;

    const RegistrationCalibration& calibration() const noexcept { return calibration_; }

private:
    DepthRegistrar() = default;
    RegistrationCalibration calibration_;
    std::vector<double> rays_; // per depth pixel: x/z, y/z of its undistorted ray (2 doubles)
    double r_[9]{};            // colour_R_depth, row-major
    double t_[3]{};
};

} // namespace lightskin::capture
