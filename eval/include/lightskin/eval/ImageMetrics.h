#pragma once
// Error of an image against a reference, both linear (radiance-proportional) float images of the
// same size and channel count (CV_32FC1 or CV_32FC3). Used by the replay regression suite, the GI
// accuracy tests and `lightskin bench`.

#include <opencv2/core/mat.hpp>

#include <string>

namespace lightskin::eval {

struct ImageError {
    /// sum |x - r| / sum |s| over the compared pixels and channels, where s is
    /// ImageErrorOptions::signal (the part of the reference a comparison must resolve, e.g. the
    /// indirect light inside a composite) or, without one, the reference itself. A uniform change
    /// of the signal by a factor k gives exactly |k - 1|. 0 when both sums are 0; +inf when only
    /// the signal's is.
    double relativeMeanAbsoluteError = 0.0;
    /// mean over pixels and channels of (x - r)^2 / (r^2 + 0.01): relative MSE, the 0.01 keeps dark
    /// pixels from dominating (as in the denoising literature).
    double relativeMse = 0.0;
    double meanAbsoluteError = 0.0; ///< mean |x - r|, linear units
    double maxAbsoluteError = 0.0;  ///< max |x - r|
    /// Mean SSIM over channels (OpenCV quality::QualitySSIM, Gaussian 11x11, sigma 1.5), computed
    /// on the images scaled by 255 / `ssimPeak` so that its constants C1, C2 (defined for a
    /// 0..255 range) apply to a 0..ssimPeak linear range. 1 = identical.
    double ssim = 1.0;
    /// 10 log10(peak^2 / MSE) with peak = ssimPeak; +inf when identical.
    double psnr = 0.0;
    std::size_t pixelsCompared = 0;
    /// Largest relativeMeanAbsoluteError of one region (ImageErrorOptions::regionGrid): the compared pixels'
    /// bounding box cut into regionGrid x regionGrid cells, each cell's sum |x - r| over its sum |s|, the latter
    /// floored at 0.1 of what the cell's pixels would hold at the image's mean |s| (so that a dark cell's noise
    /// cannot blow the ratio up). Cells with fewer than ImageErrorOptions::minRegionPixels compared pixels, or
    /// fewer than half their share (pixelsCompared / regionGrid^2), are skipped. A change of the signal by a
    /// factor k over a whole cell reads |k - 1| there (or less in a cell below 0.1 of the mean signal), whatever the
    /// rest of the image does. 0 when no cell qualifies or regionGrid is 0.
    double maxRegionRelativeMeanAbsoluteError = 0.0;
    std::size_t regionsCompared = 0; ///< cells that qualified

    std::string describe() const;
};

struct ImageErrorOptions {
    /// Linear value mapped to 255 for SSIM and used as PSNR peak (1 = display white).
    double ssimPeak = 1.0;
    /// Optional CV_8UC1 mask: only pixels where mask != 0 count (SSIM still uses the whole image).
    cv::Mat mask;
    /// Optional image of the reference's size and type: the signal relativeMeanAbsoluteError is
    /// relative to (empty: the reference). May have any sign (e.g. a difference of two images).
    cv::Mat signal;
    /// Cells per side of the region metric (maxRegionRelativeMeanAbsoluteError); 0 = not computed.
    int regionGrid = 0;
    /// Fewest compared pixels a cell needs to count.
    std::size_t minRegionPixels = 32;
};

/// Throws lightskin::Error when sizes or types differ, or when either image has NaN/inf.
ImageError compareImages(const cv::Mat& image, const cv::Mat& reference, const ImageErrorOptions& options = {});

/// Number of non-finite values (NaN or +-inf) in a float image.
std::size_t countNonFinite(const cv::Mat& image);

} // namespace lightskin::eval
