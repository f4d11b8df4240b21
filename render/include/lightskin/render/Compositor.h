#pragma once
// Compositing the rendered virtual layers onto the colour camera image. Inputs per frame, all of the colour
// camera's size: camera image CV_8UC3 BGR sRGB; virtual colour CV_8UC4 RGBA from Renderer::readOutputsInto
// (a = 255 covered, 0 not; pinhole part of the intrinsics); virtual depth CV_32FC1 camera-frame z in metres
// (0 = not covered); real depth CV_32FC1 metres registered to colour, 0 = missing (may be empty: no occlusion).
// With distortion the virtual layers are warped (nearest neighbour, maps from create()).
// out = round(camera * (1 - a) + virtual * a), a = coverage * visibility(z_virtual, z_real) (soft band, see
// visibility()); where a == 0 the camera pixel is copied, so without virtual content output == input bit for bit.

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/gi/differential/DifferentialIrradiance.h>
#include <lightskin/render/Scene.h>

#include <opencv2/core/mat.hpp>

#include <string>

namespace lightskin::render {

/// Kinect v1 axial noise sigma_z(z) = 0.0012 + 0.0019 (z - 0.4)^2 metres (Nguyen et al. 2012).
float kinectAxialNoiseMetres(float zMetres) noexcept;

/// Weight in [0,1] of a virtual surface at z_virtual over a real surface at z_real (metres):
/// clamp((z_real - z_virtual) / (2 b) + 0.5, 0, 1), b = max(minSoftBandMetres, softBandSigmas *
/// sigma_z(z_virtual)). 1 when z_real is 0 (missing) or not finite.
float visibility(float zVirtual, float zReal, const CompositeSettings& settings) noexcept;

class Compositor {
public:
    Compositor() = default;
    /// Throws lightskin::Error on invalid intrinsics.
    static Compositor create(const CameraIntrinsics& colourIntrinsics, const CompositeSettings& settings = {});

    /// Writes the composite into `out` (CV_8UC3, reallocated only when the size changes).
    void compositeInto(const cv::Mat& cameraBgr, const cv::Mat& virtualRgba, const cv::Mat& virtualDepth,
                       const cv::Mat& realDepthMetres, cv::Mat& out);

    /// The same composite in linear light, CV_32FC3 BGR (reallocated only when the size changes),
    /// from Renderer::readLinearOutputInto's `virtualLinear` (CV_32FC4 RGBA) and the 8-bit outputs
    /// (coverage, depth) as above: where a == 0 the camera pixel decoded from sRGB; where a == 1 the
    /// virtual linear value unchanged (> 1, NaN and inf kept); in between (the soft band) the 8-bit
    /// blend recomputed in float, sRGB-decoded: camera * (1 - a) + encode(clamp(virtual, 0, 1)) * a,
    /// with a non-finite virtual value passed through. sRGB-encoding and rounding this image
    /// gives compositeInto()'s output within 1 code value (its 8-bit rounding of the virtual colour).
    void compositeLinearInto(const cv::Mat& cameraBgr, const cv::Mat& virtualLinear, const cv::Mat& virtualRgba,
                             const cv::Mat& virtualDepth, const cv::Mat& realDepthMetres, cv::Mat& out);

    /// Which pixels of the virtual layers (the render's pinhole grid, the inputs of compositeInto(); the grid
    /// of Renderer's G-buffer and indirect image) the composite shows: `visible` (CV_8UC1, reallocated only
    /// when the size changes) is 255 where compositeInto() blends a share a > 0 of that pixel into some output
    /// pixel, a = coverage alpha * visibility(z_virtual, z_real) as above, computed by the same code; 0 where
    /// the pixel is uncovered or hidden behind the real depth (a == 0: the camera pixel is copied). A pixel in
    /// the soft band (0 < a < 1) counts as shown. With distortion: the pixels the warp takes an output pixel
    /// from. For measures of what the user sees (eval::measureSpeckle; docs/BENCHMARKS.md).
    void visibleInto(const cv::Mat& virtualRgba, const cv::Mat& virtualDepth, const cv::Mat& realDepthMetres,
                     cv::Mat& visible);

    const CompositeSettings& settings() const noexcept { return settings_; }

private:
    CameraIntrinsics intrinsics_;
    CompositeSettings settings_;
    cv::Mat mapX_, mapY_; ///< distorted pixel -> undistorted render pixel (empty without distortion)
    cv::Mat warpedColour_, warpedDepth_, warpedLinear_;
    cv::Mat renderIndex_, warpedIndex_; ///< with distortion: each render pixel's index, and its warp (visibleInto)
};

/// Differential rendering on the camera image (Debevec 1998): L_final = L_camera + rho / pi * dE, with the real
/// albedo rho = clamp(pi * L_camera / E_without, 0, 1) estimated per pixel and channel from the camera
/// (L_camera = the sRGB-decoded camera value / 2^exposureStops); pixels with E_without <= 0,
/// differential.affected == 0 or dE == 0 are copied bit for bit. Why this estimate and the clamp: docs/LIGHTSKIN.md,
/// "Differential irradiance". `cameraBgr` CV_8UC3 sRGB; the differential images of its size; `out` CV_8UC3 (reallocated
/// only when the size changes; must not alias the camera image).
void applyDifferentialInto(const cv::Mat& cameraBgr, const gi::DifferentialImages& differential, float exposureStops,
                           cv::Mat& out);

/// Two equally sized BGR images side by side with a caption on each (the paper's figure 4:
/// "with GI" / "without GI"). Writes into `out`.
void sideBySideInto(const cv::Mat& left, const std::string& leftCaption, const cv::Mat& right,
                    const std::string& rightCaption, cv::Mat& out);

} // namespace lightskin::render
