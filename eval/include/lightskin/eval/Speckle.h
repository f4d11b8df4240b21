#pragma once
// Speckle of an indirect-light image: the share of the virtual content's pixels that stand out
// from their neighbourhood (grey patches, dark streaks, isolated black pixels), which a noisy VAL
// set or an unstable gather produce and a smooth indirect image does not. A pixel is speckle when
// its luminance differs from its 5x5 median by more than 50 % (floored at a tenth of the mean, so
// shadowed regions do not count) and no straight profile through its neighbours explains it; the
// median tolerates 12 outliers of 25, so an isolated outlier is found exactly once. The full
// definition, and why each rule is there: docs/TESTING.md, "The speckle measure".

#include <opencv2/core/mat.hpp>

#include <cstddef>
#include <string>

namespace lightskin::eval {

struct SpeckleStats {
    std::size_t interiorPixels = 0; ///< covered pixels with a fully covered 5x5 neighbourhood
    std::size_t specklePixels = 0;
    std::size_t blackPixels = 0; ///< subset of specklePixels (see above)
    std::size_t blownPixels = 0; ///< subset of specklePixels, incl. non-finite
    double meanLuminance = 0.0;  ///< mean Y over the interior (finite pixels), linear units
    double speckleFraction() const noexcept {
        return interiorPixels ? double(specklePixels) / double(interiorPixels) : 0.0;
    }
    std::string describe() const;
};

/// Measures `linearBgr` (CV_32FC3, linear, any scale) inside `coverage` (CV_8UC1 of the same size,
/// != 0 = virtual content). `map` (optional): CV_8UC1, 0 outside the interior, 64 interior, 255
/// speckle (for looking at where it is). `smooth` (optional, CV_8UC1, e.g. smoothSurfaceMaskInto() ANDed
/// with the composite's visible mask, see "What the user sees"): the interior is further restricted to
/// pixels where it is != 0; the windows are not. `smoothProfiles` false: the
/// median test alone (the definition before the smooth-profile refinement, for comparison).
/// `backFacing` (optional, CV_8UC1 of the same size, != 0 = a back face, e.g. the G-buffer normal's w,
/// mr::FrameOutput::backFacing): those pixels leave the interior and every window's median (above).
/// Throws lightskin::Error on other types or sizes.
SpeckleStats measureSpeckle(const cv::Mat& linearBgr, const cv::Mat& coverage, cv::Mat* map = nullptr,
                            const cv::Mat& smooth = cv::Mat(), bool smoothProfiles = true,
                            const cv::Mat& backFacing = cv::Mat());

/// The part of `coverage` where the true indirect light can be expected to be smooth at the 5x5
/// scale of the measure: covered pixels whose 5x5 neighbourhood is one continuous surface patch:
/// every neighbour covered, its normal within `maxNormalAngleDegrees` of the centre's and its depth
/// within `maxRelativeDepthStep` x the centre's depth. Across creases and occlusion edges inside an
/// object (an ear in front of the head) irradiance legitimately jumps by more than 50 %, so those
/// pixels say nothing about speckle. `normals`: CV_32FC3 unit normals; `depth`: CV_32FC1 metres;
/// `mask` (sized by the call): CV_8UC1 255 = smooth. Throws lightskin::Error on bad types or sizes.
///
/// `normalSensitivity` (optional, CV_32FC1 of the same size; a proposal, not in the bench's headline
/// numbers): per pixel S = the relative change of the true irradiance per radian of normal tilt
/// (gi::reference::irradianceNormalSensitivity). A pixel whose normal is Delta from its window's mean
/// normal is left out where S Delta > 0.5, as its light may then differ by the measure's 50 % from its
/// normal alone. S <= 0 adds nothing; S = +inf keeps only windows of equal normals; NaN drops the pixel.
void smoothSurfaceMaskInto(const cv::Mat& coverage, const cv::Mat& normals, const cv::Mat& depth,
                           double maxNormalAngleDegrees, double maxRelativeDepthStep, cv::Mat& mask,
                           const cv::Mat& normalSensitivity = cv::Mat());

/// Luminance Y of a CV_32FC3 BGR linear image into a CV_32FC1 image (sized by the call).
void luminanceInto(const cv::Mat& linearBgr, cv::Mat& luminance);

} // namespace lightskin::eval
