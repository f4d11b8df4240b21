#pragma once
// The room model in the frame loop: it fuses every frame whose tag pose is trusted (TrackingState::Tracking) and,
// when the tags are lost or unreliable (Held, Lost), tracks the camera by ICP of the frame's depth against the
// model rendered from the previous pose (frame-to-model, as KinectFusion), giving TrackingState::DepthTracked.
//
// Back to the tags without a jump: on the first tag-tracked frame after depth tracking the camera-frame offset
// D = tag^-1 * depth (both poses of that frame) is measured, and the output is tag * D^s with s falling linearly
// from 1 to 0 over `blendFrames` frames (D^s: slerp of the rotation from identity, s times the translation). The
// output moves at most |D| / blendFrames per frame beyond the camera's own motion. docs/ARCHITECTURE.md,
// "Tracking states and pose flips".
//
// Frames and units as RoomModel.h: world_T_camera of the colour camera, metres; depth CV_32FC1 metres registered
// to the colour image, 0 = missing. Depth larger than the processing size is subsampled (nearest) to it.
// Ownership: owns its RoomModel and scratch images (sized on the first frame, then reused). Not thread-safe.

#include <lightskin/roommodel/RoomModel.h>
#include <lightskin/tracking/PoseTracker.h>

#include <opencv2/core/mat.hpp>

#include <filesystem>
#include <memory>
#include <string>

namespace lightskin::roommodel {

struct DepthTrackingSettings {
    /// Off: the model is fused but Held/Lost frames stay as the tag tracker says.
    bool enabled = true;
    /// Tag-tracked frames over which the pose returns from the depth pose to the tag pose (>= 1; 1 = at once).
    int blendFrames = 8;
    /// Depth-tracked frames in a row after which the state becomes Lost (ICP drift is unbounded without tags).
    int maxFrames = 300;
    /// ICP starts from a constant-velocity prediction (the previous frame's motion repeated); a result that
    /// departs from it by more than these is refused as a wrong convergence, metres and degrees per frame.
    double maxCorrectionMetres = 0.05;
    double maxCorrectionDegrees = 5.0;
    /// Width ICP runs at, pixels (the frame's depth subsampled, the model rendered at it). The model's render is
    /// the dearest step (a ray march per pixel): 160 costs a quarter of 320 (docs/BENCHMARKS.md "Room memory").
    int trackingWidth = 160;
    /// Fraction of the tracking image that must have depth, in the frame and in the model's view, for ICP.
    double minValidFraction = 0.15;
    /// Views whose RoomMemoryStats::constraintRatio is below this are not depth-tracked: ICP would slide. 0.04:
    /// on synth-orbit's room the ratio falls from 0.1 to 0.044 (pose 1.7 cm off) and 0.034 (7.5 cm off) as
    /// the view leaves the fused part of the room (docs/BENCHMARKS.md "Room memory").
    double minConstraintRatio = 0.04;
};

struct RoomMemorySettings {
    RoomModelSettings model;
    DepthTrackingSettings depthTracking;
    /// Width the depth is processed at, pixels (fusion and ICP); wider depth is subsampled by an integer factor.
    int processingWidth = 320;
};

/// Throws lightskin::Error (source `sourceName`, cause "<pointer>/<key>: ...") for settings out of range.
void validate(const RoomMemorySettings& settings, const std::string& sourceName, const std::string& pointer);

/// Parses the scene's "roomModel" object (docs/SCENE_FORMAT.md). Throws lightskin::Error with source
/// `sourceName` and a cause "<pointer>/<key>: ..." for unknown keys, wrong types or values out of range.
RoomMemorySettings roomMemorySettingsFromJson(const std::string& jsonObjectText, const std::string& sourceName,
                                              const std::string& pointer);

struct RoomMemoryStats {
    double fuseMs = -1.0;   ///< integration of this frame; -1 when not integrated
    double trackMs = -1.0;  ///< depth tracking (subsampling, model render, ICP); -1 when not run
    double renderMs = -1.0; ///< of which the model's render
    /// How well the model's view fixes all six motions: smallest / largest eigenvalue of ICP's point-to-plane
    /// normal matrix (points centred and scaled to unit mean distance: Gelfand et al., "Geometrically stable
    /// sampling for the ICP algorithm", 3DIM 2003). Near 0: some motion is free (a flat wall alone lets the
    /// camera slide along it). -1 when not computed.
    double constraintRatio = -1.0;
};

class RoomMemory {
public:
    /// Throws lightskin::Error naming the key for invalid settings.
    static RoomMemory create(const RoomMemorySettings& settings);

    RoomMemory(RoomMemory&&) noexcept;
    RoomMemory& operator=(RoomMemory&&) noexcept;
    ~RoomMemory();

    /// One frame: `depthMetres` (CV_32FC1, registered to `intrinsics`' image) and the tag tracker's result,
    /// which this completes: Tracking frames are fused (their pose may be blended, see above); Held and Lost
    /// frames become DepthTracked with a depth pose when ICP succeeds (after a failure, not before the next tag
    /// frame: the held pose is stale).
    /// Empty depth: the result is left alone.
    void update(const cv::Mat& depthMetres, const CameraIntrinsics& intrinsics, tracking::TrackingResult& result);
    /// Forgets the model and the pose history.
    void reset();
    /// Replaces the model by a saved one (RoomModelFile.h: the same grid, else lightskin::Error naming the file,
    /// and nothing changes) and forgets the pose history. Save with saveRoomModel(model(), file).
    void loadModel(const std::filesystem::path& file);

    const RoomModel& model() const noexcept;
    const RoomMemorySettings& settings() const noexcept;
    const RoomMemoryStats& lastStats() const noexcept;

private:
    struct Impl;
    explicit RoomMemory(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::roommodel
