#pragma once
// Software depth-to-colour registration: reprojects a depth image of the depth (IR) camera into the colour
// camera, for sources whose depth the device did not register (.oni without registration, fakenect, raw
// disparity, unregistered recordings). Collisions keep the nearest depth; colour pixels no depth pixel reaches
// stay 0 (nothing is interpolated). Not cv::rgbd::registerDepth: it allocates per call and ignores the depth
// distortion. create() allocates its tables once; registerInto() does not allocate.
// Units: depth in raw sensor units on both sides (metres = value * depthScaleMetres); the registered value is
// the depth along the colour camera's optical axis. The method, its limits and the comparison with OpenCV:
// docs/ARCHITECTURE.md, "Depth-to-colour registration".

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
