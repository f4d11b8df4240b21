#pragma once
// AprilTag detection with Debian's libapriltag 3.3 (the C library stays behind this interface).
//
// Pixel convention: OpenCV's, (0,0) is the centre of the top-left pixel. (libapriltag 3.3 itself
// reports coordinates 0.5 px larger, pixel centres at +0.5; TagDetector converts, so its corners
// are the library's minus 0.5.) Corners are in the pixel coordinates of the image given to
// detect(); PoseTracker undistorts them when the camera has lens distortion.

#include <lightskin/tracking/TagFamily.h>

#include <glm/vec2.hpp>
#include <opencv2/core/mat.hpp>

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace lightskin::tracking {

/// The library's tunables, with the library's defaults unless stated, and what each one trades.
struct DetectorSettings {
    /// Tag family (see supportedTagFamilies()). Default tag36h11: 587 ids, minimum Hamming
    /// distance 11, the best false-positive rate among the square families.
    std::string family = defaultTagFamily;
    /// Quads are searched in an image decimated by this factor (decoding still uses the full
    /// image). 2 (default) is ~3-4x faster than 1; 4 is faster again but misses tags below
    /// ~40 px. Small tags (10-30 px) need 1. Corner accuracy is recovered by refineEdges.
    float quadDecimate = 2.0f;
    /// lightskin's own (not an apriltag option): the image is enlarged by this integer factor
    /// (bicubic) before the library sees it; corners are mapped back to the input's pixels. 1
    /// (default) = off. 2 finds small, blurred, strongly foreshortened tags the library misses at
    /// their native size: on recordings/synth-orbit (320x240 GL renders, board tags ~24 x 10 px at
    /// a grazing angle) 113 instead of 52 tags decoded in 40 frames (quadDecimate 1 both times).
    /// Costs ~3.6x the library's time (there 1.8 -> 6.5 ms per frame); quadDecimate 2 on the
    /// enlarged image gives the time back but also the misses (20 board tags instead of 73).
    /// Use it for small images with small tags, not for 640x480 and larger.
    int upsample = 1;
    /// Gaussian blur (sigma, pixels) of the segmented image. 0 (default) = none; ~0.8 helps very
    /// noisy images at the cost of small tags and a little time.
    float quadSigma = 0.0f;
    /// Worker threads of the library. 1 (default) leaves the cores to the GI stages; more threads
    /// cut latency roughly linearly up to the core count.
    int threads = 1;
    /// Snap quad edges to strong image gradients. Default true: nearly free and essential for
    /// sub-pixel corners when quadDecimate > 1. false reproduces the upstream test outputs.
    bool refineEdges = true;
    /// Sharpening of the sampled bits before decoding. 0.25 (default) helps small tags decode;
    /// larger values can hurt in low light or with strong noise.
    double decodeSharpening = 0.25;
    /// lightskin's own sub-pixel step after the library (not an apriltag option): each border edge
    /// is re-located from the intensity gradient along its normal at up to 40 points (search
    /// window < half a bit cell, so the data bits are never mistaken for it), a line is fitted per
    /// edge and the corners are the lines' intersections. Default true: on rendered tags of 48 px
    /// and more it cuts the corner error ~3x (RMS 0.078 -> 0.026 px with decimate 2 +
    /// refineEdges); tags with less than 6 px per bit cell keep the library's corners (there the
    /// refinement measured worse on blurred renders). false gives the library's corners
    /// unchanged. Costs ~10 us per tag.
    bool refineCorners = true;
    /// Detections with more corrected bits are dropped. 0..2 (the library corrects at most 2).
    /// Default 0: every corrected bit raises the false-positive rate a lot; 1 helps motion blur.
    int maxHamming = 0;
    /// Detections whose decision margin (mean distance of the bits from the decode threshold,
    /// grey levels 0..255) is below this are dropped. Default 20: real tags are typically 40+,
    /// spurious decodes in clutter below 20. The margin is meaningful mostly for small tags.
    float minDecisionMargin = 20.0f;
};

/// Reads detector settings from a JSON object text (scene files' /tracking/detector), starting from
/// `defaults`. Keys, all optional: family, quadDecimate, quadSigma, threads, refineEdges,
/// decodeSharpening, refineCorners, maxHamming, minDecisionMargin, upsample. Unknown keys, wrong types and
/// values out of range throw lightskin::Error in the scene file's format: source `sourceName` (the file),
/// cause "<pointer>/<key>: expected ..., got ..." with `pointer` the object's JSON pointer in that file
/// (e.g. "/tracking/detector"; empty for a file that holds only the settings).
DetectorSettings detectorSettingsFromJson(const std::string& jsonObjectText, const std::string& sourceName,
                                          const std::string& pointer = {}, const DetectorSettings& defaults = {});

/// A setting the library cannot use: its JSON key (as detectorSettingsFromJson reads it) and the
/// cause ("expected a number in [1, 16], got -2").
struct DetectorSettingProblem {
    std::string key;
    std::string cause;
};
/// The first setting of `settings` out of its range (the ranges TagDetector::create accepts), or none.
std::optional<DetectorSettingProblem> findDetectorSettingProblem(const DetectorSettings& settings);

struct TagDetection {
    int id = -1;
    /// Corrected bits (0..2).
    int hamming = 0;
    /// See DetectorSettings::minDecisionMargin.
    float decisionMargin = 0.0f;
    /// Corners of the black-border square, pixels. Order (the library's): counter-clockwise on
    /// screen starting at the tag's bottom-left, i.e. the tag-frame corners
    /// (-s/2,-s/2), (s/2,-s/2), (s/2,s/2), (-s/2,s/2) of TagFamily.h's tag frame.
    std::array<glm::dvec2, 4> corners{};
    /// Centre of the detection (the homography's image of the tag centre), pixels.
    glm::dvec2 centre{0.0};
};

/// Owns one apriltag_detector_t and its family (create/destroy pairs); move-only. Not thread-safe:
/// one detector per thread.
class TagDetector {
public:
    /// Throws lightskin::Error for an unknown family or settings outside their ranges.
    static TagDetector create(const DetectorSettings& settings = {});

    TagDetector(TagDetector&&) noexcept;
    TagDetector& operator=(TagDetector&&) noexcept;
    TagDetector(const TagDetector&) = delete;
    TagDetector& operator=(const TagDetector&) = delete;
    ~TagDetector();

    /// Detects tags in `grey` (CV_8UC1, any size; BGR CV_8UC3 is converted first) and writes the
    /// detections that pass the Hamming and decision-margin filters into `out` (cleared first),
    /// sorted by id. Returns the number of detections the library reported before filtering.
    int detectInto(const cv::Mat& image, std::vector<TagDetection>& out);
    std::vector<TagDetection> detect(const cv::Mat& image);

    const DetectorSettings& settings() const noexcept;

private:
    struct Impl;
    explicit TagDetector(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::tracking
