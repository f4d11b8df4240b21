#pragma once
// Edge-preserving bilateral filter for depth maps (KinectFusion's pre-filter, Newcombe et al.
// 2011), on depth in metres with OpenCV's cv::bilateralFilter.
//
// Missing depth (0) stays missing and takes no part in the filter: cv::bilateralFilter alone
// would treat 0 as a depth, so a valid pixel next to a hole is pulled toward 0 as soon as the
// range weight exp(-z^2 / 2 sigma_depth^2) of a zero neighbour is not negligible (near depths or
// a large sigma_depth), and a hole pixel becomes a weighted mix of its neighbours. We therefore
// fill holes with a sentinel 15 sigma_depth beyond the deepest valid pixel (range weight
// exp(-112.5) = 1e-49, which is 0 in float), filter, and set holes back to 0. That is exactly a
// normalised bilateral filter whose weights are multiplied by a validity mask, run by OpenCV's
// optimised (parallel, SIMD) implementation; away from holes it is cv::bilateralFilter itself.
//
// The kernel is OpenCV's: a disk of diameter kernelSize (pixels within kernelSize/2 of the centre)
// with spatial weight exp(-r^2 / 2 sigma_space^2) and range weight exp(-dz^2 / 2 sigma_depth^2).

#include <opencv2/core/mat.hpp>

#include <limits>

namespace lightskin::capture {

struct BilateralDepthFilterParams {
    int kernelSize = 7;             ///< odd diameter, pixels (KinectFusion: 7)
    double sigmaSpacePixels = 4.5;  ///< spatial Gaussian sigma, pixels
    double sigmaDepthMetres = 0.03; ///< range Gaussian sigma, metres (Kinect noise ~1-3 cm at 1-3 m)
    /// Optional range clamp: depth outside [min, max] metres is treated as missing (output 0)
    /// and does not influence its neighbours. Defaults keep every positive depth.
    double minDepthMetres = 0.0;
    double maxDepthMetres = std::numeric_limits<double>::infinity();
};

class BilateralDepthFilter {
public:
    explicit BilateralDepthFilter(const BilateralDepthFilterParams& params = {});

    /// Filters `depth` (CV_16UC1 raw units times `depthScaleMetres`, or CV_32FC1 metres with
    /// scale 1) into `outMetres` (CV_32FC1 metres, 0 = missing). `outMetres` and the internal
    /// buffers are allocated on the first call and reused while the size stays the same
    /// (cv::bilateralFilter still makes its own bordered copy per call). `outMetres` must not
    /// share memory with `depth`.
    void filterInto(const cv::Mat& depth, double depthScaleMetres, cv::Mat& outMetres);
    /// Allocating convenience form of filterInto().
    cv::Mat filter(const cv::Mat& depth, double depthScaleMetres);

    const BilateralDepthFilterParams& params() const noexcept { return params_; }

private:
    BilateralDepthFilterParams params_;
    cv::Mat metres_, valid_, invalid_;
};

} // namespace lightskin::capture
