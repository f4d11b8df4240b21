#pragma once
// Edge-preserving bilateral filter for depth maps (KinectFusion's pre-filter, Newcombe et al.
// 2011), on depth in metres.
//
// The filter: a normalised bilateral filter whose weights are multiplied by a validity mask, on
// OpenCV's kernel: a disk of diameter kernelSize (pixels within kernelSize/2 of the centre) with
// spatial weight exp(-r^2 / 2 sigma_space^2) and range weight exp(-dz^2 / 2 sigma_depth^2), the
// centre weight 1, borders replicated. Missing depth (0) stays missing (output 0) and takes no part:
// a valid pixel next to a hole is not pulled toward 0, and a hole is not filled.
//
// Two implementations of that one filter (BilateralDepthFilterParams::implementation):
//  * Simd (the default): one pass of our own, SIMD across a row's pixels (Google Highway, runtime
//    dispatch), exact range weights (a polynomial 2^x, relative error < 3e-7), one thread. 2.8x less
//    CPU than the OpenCV one per 640x480 frame (docs/BENCHMARKS.md, "Capture: depth bilateral filter").
//  * OpenCv: cv::bilateralFilter, with holes filled by a sentinel 15 sigma_depth beyond the deepest
//    valid pixel (range weight exp(-112.5) = 1e-49, 0 in float) and set back to 0 after. Its range
//    weights come from a 4096-entry table over [min, max] of the image, linearly interpolated, so
//    it differs from Simd by that table's error: 0.008 mm at most on the Kinect v1 .oni, within a
//    per-pixel bound derived in tests/capture/DepthFilterOniTest.cpp. Kept to compare with.

#include <opencv2/core/mat.hpp>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace lightskin::capture {

enum class BilateralImplementation : std::uint8_t {
    Simd,   ///< our row kernel (SIMD, exact range weights, one thread)
    OpenCv, ///< cv::bilateralFilter with a hole sentinel (interpolated range table, OpenCV's threads)
};

struct BilateralDepthFilterParams {
    int kernelSize = 7;             ///< odd diameter, pixels (KinectFusion: 7)
    double sigmaSpacePixels = 4.5;  ///< spatial Gaussian sigma, pixels
    double sigmaDepthMetres = 0.03; ///< range Gaussian sigma, metres (Kinect noise ~1-3 cm at 1-3 m)
    /// Optional range clamp: depth outside [min, max] metres is treated as missing (output 0)
    /// and does not influence its neighbours. Defaults keep every positive depth.
    double minDepthMetres = 0.0;
    double maxDepthMetres = std::numeric_limits<double>::infinity();
    BilateralImplementation implementation = BilateralImplementation::Simd; ///< same filter, see above
};

class BilateralDepthFilter {
public:
    explicit BilateralDepthFilter(const BilateralDepthFilterParams& params = {});

    /// Filters `depth` (CV_16UC1 raw units times `depthScaleMetres`, or CV_32FC1 metres with
    /// scale 1) into `outMetres` (CV_32FC1 metres, 0 = missing). `outMetres` and the internal
    /// buffers are allocated on the first call and reused while the size stays the same
    /// (the OpenCv implementation's cv::bilateralFilter still makes its own bordered copy per
    /// call). `outMetres` must not share memory with `depth`.
    void filterInto(const cv::Mat& depth, double depthScaleMetres, cv::Mat& outMetres);
    /// Allocating convenience form of filterInto().
    cv::Mat filter(const cv::Mat& depth, double depthScaleMetres);

    const BilateralDepthFilterParams& params() const noexcept { return params_; }

private:
    void filterOpenCv(const cv::Mat& depth, double depthScaleMetres, cv::Mat& outMetres);
    void filterSimd(const cv::Mat& depth, double depthScaleMetres, cv::Mat& outMetres);

    BilateralDepthFilterParams params_;
    cv::Mat metres_, valid_, invalid_; // OpenCv
    std::vector<float> padded_;        // Simd: metres, missing = sentinel, bordered by the radius
    std::vector<std::ptrdiff_t> tapOffsets_;
    std::vector<float> tapLog2Space_;
    std::size_t paddedStride_ = 0;
};

} // namespace lightskin::capture
