#pragma once
// Per-frame camera tracking: detection -> pose -> temporal filter, with an honest state.
// Output: world_T_camera of the COLOUR camera (camera frame x right, y down, z forward; world frame from the
// TagWorld; metres).
// States: Tracking (this frame's tags gave an accepted, filtered pose); Held (no acceptable measurement: the last
// pose repeated, not extrapolated, for at most TrackerSettings::maxHeldFrames frames); Lost (no pose, empty
// world_T_camera: rendering must not place virtual content with it); DepthTracked (never set by the PoseTracker:
// the room memory, roommodel/RoomMemory.h, tracked a Held or Lost frame by ICP of its depth against the room
// model). A pose flip is never silent: it is rejected (Held) or flagged (`poseJumped`, `ambiguous`). When each
// state is entered and how flips are resolved: docs/ARCHITECTURE.md, "Tracking states and pose flips".

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/RgbdFrame.h>
#include <lightskin/tracking/PoseEstimation.h>
#include <lightskin/tracking/PoseFilter.h>
#include <lightskin/tracking/TagDetector.h>
#include <lightskin/tracking/TagWorld.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

namespace lightskin::tracking {

enum class TrackingState : std::uint8_t { Tracking, Held, Lost, DepthTracked };
const char* toString(TrackingState state) noexcept;

enum class Undistortion : std::uint8_t {
    /// Detect in the distorted image, undistort the corners (cv::undistortPoints). Cheap; fine for
    /// the mild distortion of Kinect-class cameras. Default.
    Corners,
    /// Undistort the whole image first (cv::remap, maps built once per intrinsics): straight tag
    /// edges for strongly distorted lenses, at ~1-2 ms per VGA frame.
    Image,
};

struct TrackerSettings {
    /// The world's family overrides detector.family.
    DetectorSettings detector;
    Undistortion undistortion = Undistortion::Corners;
    /// Measurements with a larger RMS corner reprojection error are rejected (pixels).
    double maxReprojectionErrorPx = 3.0;
    /// Second-best / best reprojection error at or above which the best single-tag solution is
    /// trusted without history. Below it the view is ambiguous.
    double ambiguityRatio = 4.0;
    /// Below this ratio (and only there) an ambiguous single-tag view takes the solution closer to
    /// the previous pose instead of the better-fitting one. Between it and ambiguityRatio the fit
    /// still decides: on the synth-orbit recording (a far, small wall tag) history alone locked
    /// onto a wrong branch inherited from earlier noisy frames, while the better fit was right
    /// at ratios 2.2-3.7; at ratios 1.0-1.7 the fit was a coin toss and history was better.
    double historyRatio = 2.0;
    /// Measurements that place the world's own tags worse than this are Held ("pose poorly
    /// determined") instead of Tracking with a pose that may be centimetres off. Measured by
    /// PoseUncertainty::worldCornerStdPx, the projection std of every corner of every world tag, seen
    /// or not: it refuses a bundle seen through one small or distant tag, never a single-tag world.
    /// 3.4 px = f tan(1.5 deg) / 2 at the smallest focal length run (262.5 px), the pose-error budget
    /// at 2 sigma (docs/TESTING.md "Pose-error budget"). Infinity switches the check off.
    double maxWorldCornerStdPx = 3.4;
    /// Largest orientation change accepted for an ambiguous measurement, degrees per frame.
    double maxJumpDegrees = 25.0;
    /// Frames the last pose is held without a measurement before the state becomes Lost.
    int maxHeldFrames = 10;
    /// Depth-aided refinement of single-tag poses (refinePoseWithDepth); needs depth registered to
    /// the colour image and, with lens distortion, Undistortion::Image is not enough: skipped then.
    bool useDepth = false;
    /// Frame interval assumed when timestamps are missing or not increasing, seconds.
    double nominalFrameIntervalSeconds = 1.0 / 30.0;
    PoseFilterSettings filter;
};

struct TrackingTiming {
    double preprocessMs = 0.0; ///< greyscale conversion and image undistortion
    double detectMs = 0.0;     ///< the AprilTag library
    double poseMs = 0.0;       ///< PnP, selection, depth, filter
    double totalMs = 0.0;
};

struct TrackingResult {
    std::int64_t frameIndex = 0;
    TrackingState state = TrackingState::Lost;
    /// Filtered pose; empty when Lost.
    std::optional<Pose> world_T_camera;
    /// This frame's accepted, unfiltered measurement; empty when none was accepted.
    std::optional<Pose> measured_world_T_camera;
    /// Tag ids in the world that gave the accepted measurement (empty when none was accepted).
    std::vector<int> tagsUsed;
    /// Detected ids that are not in the world (ignored).
    std::vector<int> unknownTags;
    /// Ids in the world whose corners disagreed with the other visible tags (dropped this frame).
    std::vector<int> rejectedTags;
    /// RMS corner reprojection error of the best measurement this frame, pixels; NaN without one.
    double reprojectionErrorPx = 0.0;
    /// Second-best / best error of this frame's measurement (infinity for a clear bundle view).
    double ambiguityRatio = 0.0;
    /// First-order uncertainty of the accepted measurement (PoseEstimation.h); infinite without one.
    PoseUncertainty uncertainty;
    /// The chosen solution was not clearly better than its flipped alternative.
    bool ambiguous = false;
    /// The alternative solution was chosen because it agrees with the previous pose.
    bool resolvedByHistory = false;
    /// An unambiguous measurement moved the orientation by more than maxJumpDegrees; the filter
    /// restarted from it.
    bool poseJumped = false;
    bool depthRefined = false;
    /// Consecutive frames without an accepted measurement, this one included.
    int framesWithoutMeasurement = 0;
    /// Why there is no accepted measurement (static string), or "" when there is one.
    const char* reason = "";
    TrackingTiming timing;
};

class PoseTracker {
public:
    /// Throws lightskin::Error for bad settings (see TagDetector::create).
    static PoseTracker create(TagWorld world, const TrackerSettings& settings = {});

    PoseTracker(PoseTracker&&) noexcept;
    PoseTracker& operator=(PoseTracker&&) noexcept;
    ~PoseTracker();

    /// Tracks one frame: its colour image, colourIntrinsics, colourTimestampSeconds and, with
    /// useDepth, its registered depth. Throws lightskin::Error naming the frame when the image
    /// size disagrees with the intrinsics or the intrinsics are invalid.
    void trackInto(const RgbdFrame& frame, TrackingResult& out);
    TrackingResult track(const RgbdFrame& frame);
    /// The same for a bare image (grey or BGR, 8-bit) without depth.
    void trackImageInto(const cv::Mat& image, const CameraIntrinsics& intrinsics, double timestampSeconds,
                        std::int64_t frameIndex, TrackingResult& out);

    /// Back to Lost; the filter forgets its history.
    void reset();

    const TagWorld& world() const noexcept;
    const TrackerSettings& settings() const noexcept;
    /// This frame's detections (corners undistorted), valid until the next call.
    const std::vector<TagDetection>& lastDetections() const noexcept;

    /// For replay without tracking: the frame's ground-truth pose as a Tracking result, or a Lost
    /// result (reason "no ground truth") when the frame has none.
    static TrackingResult fromGroundTruth(const RgbdFrame& frame);

private:
    struct Impl;
    explicit PoseTracker(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
    void trackImpl(const cv::Mat& image, const CameraIntrinsics& intrinsics, double timestampSeconds,
                   std::int64_t frameIndex, const RgbdFrame* depthFrame, TrackingResult& out);
};

} // namespace lightskin::tracking
