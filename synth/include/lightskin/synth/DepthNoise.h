#pragma once
// A Kinect v1-like depth noise model, seeded and reproducible: the same (seed, frame, input)
// gives the same output bit for bit, whatever the thread count or platform.
//
// The model, applied to exact depth in this order (parameters in DepthNoiseDescription):
//  1. Projector shadow: the IR projector sits `baselineMetres` from the camera along the camera x
//     axis (positive = +x). A pixel the projector cannot see is missing. Test: in each row the
//     projector column u_p = u - fx * b / z must increase with u; a pixel whose u_p exceeds the
//     smallest u_p of any pixel on its projector-ward side is behind an occluder (b > 0: the
//     shadow falls on the -x side of foreground objects, of width fx * b * (1/z_near - 1/z_far) px).
//  2. Grazing angles: with theta the angle between the surface normal and the ray to the camera,
//     the pixel is dropped with probability rising linearly from 0 at grazingStartDegrees to 1 at
//     grazingEndDegrees (the projected dots spread out and the correlation fails).
//  3. Edge holes: a pixel with a 4-neighbour more than edgeJumpRelative * z away in depth is
//     dropped with probability edgeDropoutProbability (the correlation window straddles the jump).
//  4. Lateral noise (Nguyen, Izadi, Lovell, "Modeling Kinect Sensor Noise for Improved 3D
//     Reconstruction and Tracking", 3DIMPVT 2012): sigma_L = 0.8 + 0.035 * theta / (pi/2 - theta)
//     pixels of a 640-wide, f = sensorFocalPixels sensor (scaled to the output's fx). The pixel
//     takes the depth at a position displaced by N(0, sigma_L) in u and v when that position lies
//     across a depth jump: edges jitter, smooth surfaces are left to the axial term.
//  5. Range: z outside [minRangeMetres, maxRangeMetres] is missing (Kinect v1: about 0.5-4 m).
//  6. Axial noise and disparity quantisation: the Kinect measures disparity
//     d = sensorFocalPixels * baseline / z in 1/disparitySubpixel pixel steps (1/8 px, Konolige and
//     Mihelich, "Technical description of Kinect calibration", ROS wiki, 2011; Khoshelham and
//     Elberink, Sensors 12(2), 2012). Nguyen et al.'s measured axial sigma_z(z) = 0.0012 +
//     0.0019 (z - 0.4)^2 m (10-60 degrees) already contains the quantisation, so Gaussian noise of
//     sigma_add = sqrt(max(0, sigma_z^2 - q^2 / 12)) is added to z (q = z^2 / (f b s), the
//     quantisation step in depth) before d is rounded: the output's standard deviation on a plane
//     is sigma_z(z) (within a few percent; see tests/synth/DepthNoiseTest.cpp).
// Noise is independent per pixel (the real sensor's errors are correlated over its 9x9
// correlation window; not modelled).

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/synth/SceneDescription.h>

#include <opencv2/core/mat.hpp>

#include <cstdint>

namespace lightskin::synth {

/// Nguyen et al. 2012 axial standard deviation at depth z (metres).
double kinectAxialSigmaMetres(double z) noexcept;
/// Nguyen et al. 2012 lateral standard deviation (pixels of the 640x480 sensor) at angle theta (radians).
double kinectLateralSigmaPixels(double theta) noexcept;
/// Depth step between two adjacent disparity levels at depth z (metres).
double disparityStepMetres(const DepthNoiseDescription& noise, double z) noexcept;

/// Applies the model. `exactDepth`: CV_32FC1 z in metres along the optical axis, 0 = no surface.
/// `cameraNormals`: CV_32FC3 unit surface normals in the camera frame (x right, y down, z forward).
/// `out`: CV_32FC1 metres, 0 = missing (reallocated only if its size or type differ).
/// With noise.enabled false, out is a copy of exactDepth.
/// `scratch` (CV_8UC1, the projector-shadow mask) is reused across calls: pass the same Mat every
/// frame and nothing is allocated in steady state.
void applyDepthNoiseInto(const cv::Mat& exactDepth, const cv::Mat& cameraNormals, const CameraIntrinsics& intrinsics,
                         const DepthNoiseDescription& noise, std::int64_t frameIndex, cv::Mat& out, cv::Mat& scratch);
/// As above with a scratch buffer of its own (allocates per call).
void applyDepthNoiseInto(const cv::Mat& exactDepth, const cv::Mat& cameraNormals, const CameraIntrinsics& intrinsics,
                         const DepthNoiseDescription& noise, std::int64_t frameIndex, cv::Mat& out);

} // namespace lightskin::synth
