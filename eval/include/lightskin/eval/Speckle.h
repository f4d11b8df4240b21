#pragma once
// Speckle of an indirect-light image (issue 12): how many pixels of the virtual content stand out
// from their neighbourhood, the "grey patches, dark streaks and isolated black pixels" a noisy VAL
// set or an unstable gather produce, while a smooth indirect image has none.
//
// Definition (all on linear luminance Y = 0.2126 R + 0.7152 G + 0.0722 B of a CV_32FC3 BGR image):
//  * Interior: covered pixels whose whole 5x5 neighbourhood is covered (the coverage mask eroded by
//    2 px), so object borders, where the median mixes in background, never count.
//  * m = the median of Y over the 5x5 neighbourhood (the pixel included).
//  * Speckle pixel: |Y - m| > 0.5 max(m, floor), floor = 0.1 x the mean Y of the interior, and the
//    pixel is not on a smooth profile (below). The floor
//    restricts the measure to lit neighbourhoods: where m is below a tenth of the object's mean
//    indirect level (shadowed sides, receivers facing away from all VALs) a 50 % change is a step
//    of < 5 % of that level, and smooth but steep falloffs toward 0 there (cos(theta_i) -> 0 for
//    every VAL) would count although nothing is blotchy. (With a floor of 0.01 the bench's real
//    scenes measure 0.3-1.4 %, all of it in such regions; docs/BENCHMARKS.md.)
//  * Smooth profile (issue 12: the median alone flags true light that falls steeply over 1-2 px where
//    its contour curves, e.g. on an object 2 m away, TUM fr3): the pixel is explained by its
//    neighbours if, along one of the four directions e (horizontal, vertical, both diagonals), it
//    lies on the straight line through its +-1 neighbours and on the one through its +-2 neighbours
//    (each within the same 50 % of the floored line value), and across e it is no extremum of its
//    two +-1 neighbours (within 50 % of the nearer one, floored). Any straight ramp, however steep,
//    and a falloff whose contour is straight at the 2 px scale are explained; an isolated outlier,
//    a 1 px streak (an extremum across it), every pixel of a 2x2 blotch and every pixel of a 3x3
//    blotch are not, because in each direction one of the two pairs reaches background on at least
//    one side: at the median's own contrast (> 1.5x or < 0.5x the background) for outliers, streaks
//    and 2x2 blotches; > 3x or < 1/3 for the edge pixels of a 3x3 blotch (a pair half in it), its
//    centre at 1.5x / 0.5x. Proof by construction: tests/eval/SpeckleTest.cpp.
//  * Back faces (optional mask, issue 12): pixels where the G-buffer shows a back face are the inside of
//    an object seen through a hole in its mesh (a scan's holes). Light reaches an object's inside only
//    through its holes: against the ray-traced truth with visibility, the inside of a 16 cm box seen
//    through a 4 x 4 cm hole gets 11 % of its lit outside's light on average, bounded by the holes'
//    solid angle (gi_back_face_hole_gl_test; a scan's holes of a few mm let in far less), and both GI
//    techniques write 0 there (gi::GBufferView::worldNormal). So they are not "inside a lit object":
//    they leave the interior, and the median of a front-face pixel is taken over the front-face pixels
//    of its window only (the upper middle of an even count), and a smooth-profile direction that
//    would use a back-face pixel explains nothing, so that the dark inside neither drags a
//    neighbour's median down nor passes a black front-face pixel beside a hole as a dark profile:
//    every front-face pixel is measured against its front-face neighbourhood. Back-face pixels
//    still count as covered for the 5x5 erosion (a front pixel beside a hole stays interior).
//  * Speckle fraction = speckle pixels / interior pixels.
//  * Black pixel (subset): Y < 0.1 m in a lit neighbourhood (m >= 0.1 x mean Y): a hole in the light.
//  * Blown pixel (subset): Y > 10 max(m, floor): a spike. Non-finite Y counts as blown and speckle.
//  * What the user sees (issue 12: the measure is about the composite): a covered pixel that the
//    composite hides behind the real depth (render::Compositor::visibleInto: share a = coverage x
//    visibility(z_virtual, z_real) == 0, the camera pixel is copied) is not counted; one that it shows
//    with any a > 0, the soft occlusion band included, is. Callers pass the composite's mask
//    (mr::FrameOutput::visibleCoverage, made by the compositor's own code, so no second tolerance)
//    ANDed into `smooth`: it restricts the pixels counted, while the 5x5 windows and the median still
//    see every covered pixel, so a visible pixel next to a hidden one is measured as before and every
//    visible black pixel still counts (tests/eval/SpeckleTest.cpp). Passing the visible mask as
//    `coverage` instead would erode it and drop the visible pixels along every contact line.
// A median (not a mean) of 25 samples tolerates up to 12 outliers, so a speckle pixel is one that
// differs from the bulk of its neighbourhood, and an isolated outlier in a smooth image is found
// exactly once. A smooth image (|grad Y| * 2 px < 0.5 m everywhere) has speckle 0, and so has any
// image that is linear along one direction at every pixel.

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
/// `normalSensitivity` (optional, CV_32FC1 of the same size; a proposal, issue 12 / TUM fr3, not used
/// by the bench's headline numbers): per pixel S = the relative change of the true irradiance per
/// radian of normal tilt (gi::reference::irradianceNormalSensitivity; S = tan(theta_i) for one light
/// at incidence theta_i). To first order the median of the window is the light at the window's mean
/// normal, and a pixel whose normal is Delta away from that mean can differ from it by S Delta from
/// its normal alone; the measure flags > 50 %, so the pixel is also left out where S Delta > 0.5.
/// A normal field that turns linearly across the window (Delta = 0 at its centre) stays in for any S
/// (its light is then linear too, to first order, which the smooth-profile test explains); kinks and
/// valleys of the shading normals under grazing light (S = 5-18 on the bunny's underside at TUM fr3,
/// kinks of 2-13 degrees) are left out. S <= 0 adds nothing; S = +inf (no light above the horizon)
/// keeps only pixels whose window's normals are all equal; NaN drops the pixel. A patch whose normals
/// are all equal stays in for any S, so defects there are still counted pixel for pixel.
void smoothSurfaceMaskInto(const cv::Mat& coverage, const cv::Mat& normals, const cv::Mat& depth,
                           double maxNormalAngleDegrees, double maxRelativeDepthStep, cv::Mat& mask,
                           const cv::Mat& normalSensitivity = cv::Mat());

/// Luminance Y of a CV_32FC3 BGR linear image into a CV_32FC1 image (sized by the call).
void luminanceInto(const cv::Mat& linearBgr, cv::Mat& luminance);

} // namespace lightskin::eval
