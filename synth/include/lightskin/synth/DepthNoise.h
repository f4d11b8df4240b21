#pragma once
// A Kinect v1-like depth noise model, seeded and reproducible: the same (seed, frame, input)
// gives the same output bit for bit, whatever the thread count or platform. Applied to exact depth
// (metres, camera frame; 0 = missing): projector shadow, grazing-angle and edge dropout, lateral
// jitter at edges, range limits, axial noise with disparity quantisation (Nguyen et al. 2012). The
// steps, their order and sources: docs/SYNTH.md, "The depth noise model, step by step".

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
