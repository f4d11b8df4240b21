#pragma once
// The lightskin recording format (version 1, documented in recordings/README.md): a folder with
//   lightskin-recording.json   header: version, device, intrinsics + distortion of both streams,
//                              depth scale, registration, colour_T_depth, colour encoding
//   frames.jsonl               append-only index, one JSON object per line and frame
//   depth/000000.png ...       16-bit single-channel PNG, raw units (metres = value * depthScale)
//   colour/000000.png ...      8-bit BGR PNG (lossless) or .jpg when jpegColour is set
//
// Crash safety and durability (RecordingDurability below; recordings/README.md, "Durability"): each
// frame's image files are written to a temporary name and renamed into place; index lines are
// appended in batches, each batch only after its frames' files and folders were fsync'ed, and the
// index is fsync'ed after it. So every frame the index lists is complete, after a SIGKILL and after
// a power loss alike, and such a stop loses at most the frames of the batch not yet appended. A
// reader stops at the last complete line and ignores a torn last line (no newline, or NUL bytes).
// Reading: openFrameSource(folder) (FrameSource.h) or readRecordingSummary() below.

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>
#include <lightskin/core/RgbdFrame.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace lightskin::capture {

/// Format version written by this library; readers accept versions <= this.
inline constexpr int kRecordingFormatVersion = 1;
inline constexpr const char* kRecordingHeaderFile = "lightskin-recording.json";
inline constexpr const char* kRecordingIndexFile = "frames.jsonl";

/// The per-recording facts stored in the header (the same for every frame).
struct RecordingInfo {
    std::string deviceName;
    CameraIntrinsics colourIntrinsics, depthIntrinsics;
    double depthScaleMetres = 0.001; ///< metres per depth unit
    DepthRegistration registration = DepthRegistration::RegisteredToColour;
    Pose colour_T_depth;     ///< depth camera -> colour camera, metres
    bool jpegColour = false; ///< colour as JPEG (quality jpegQuality): lossy, much smaller
    int jpegQuality = 95;
};

/// When the writer makes frames durable: at most `syncEveryFrames` frames, or `syncEverySeconds`
/// of them, wait between being written (files renamed into place) and being listed in the index.
/// That is what a kill or a power loss can lose (plus, with Recorder, the frames still queued).
/// The defaults (30 frames or 1 s: one second at 30 fps) cost one fsync per frame file per second
/// and keep a stop's loss to a second of recording.
struct RecordingDurability {
    /// Frames written but not yet in the index that trigger a sync (>= 1; 1 = every frame).
    std::int64_t syncEveryFrames = 30;
    /// Seconds since the oldest frame not yet in the index that trigger a sync (> 0).
    double syncEverySeconds = 1.0;
    /// fsync the frame files, their folders and then the index at each sync (and the header and the
    /// folders at create()). false: the same batching, no fsync: survives a kill, not a power loss.
    bool fsync = true;
};

/// Writes a recording. Move-only; the destructor finishes a recording that was not finished.
/// Not thread-safe: one thread writes (Recorder.h puts it behind a queue and a writer thread).
class RecordingWriter {
public:
    /// Creates `folder` (and parents) and writes the header. Throws lightskin::Error when the
    /// folder already holds a recording or files, or cannot be written, or `info` is invalid.
    /// With `durability.fsync` the header, the folder and its parent are fsync'ed before create() returns.
    static RecordingWriter create(const std::filesystem::path& folder, const RecordingInfo& info,
                                  const RecordingDurability& durability = {});

    RecordingWriter(RecordingWriter&&) noexcept;
    RecordingWriter& operator=(RecordingWriter&&) noexcept;
    ~RecordingWriter();

    /// Appends one frame: its depth (CV_16UC1, sizes as in the header's depth intrinsics) and
    /// colour (CV_8UC3 BGR, colour intrinsics' size), timestamps, and groundTruth_world_T_camera
    /// when set. Either image may be empty (not recorded for that frame), not both. The frame's
    /// index field is ignored: frames are numbered 0, 1, 2, ... in write order.
    /// The frame is listed in the index at the next sync (RecordingDurability), which write() runs
    /// when one is due. Throws lightskin::Error (folder, frame, cause) when the frame does not match
    /// the header or the disk refuses; the recording stays readable up to the last synced frame. A
    /// failed sync loses the frames it was to list (framesWritten() falls back to framesListed()).
    void write(const RgbdFrame& frame);
    /// Syncs now when frames wait and the oldest waited syncEverySeconds (for a writer whose source
    /// paused); returns whether it synced. Throws like write().
    bool syncIfDue();
    /// Makes every written frame durable and listed now. Throws like write().
    void sync();
    /// Syncs, appends the end marker and closes the index (fsync'ed). Idempotent.
    void finish();
    std::int64_t framesWritten() const; ///< frames whose files are written (listed or waiting for a sync)
    std::int64_t framesListed() const;  ///< frames in the index (durable per RecordingDurability)
    const std::filesystem::path& folder() const;
    const RecordingInfo& info() const;

private:
    struct State;
    explicit RecordingWriter(std::unique_ptr<State> state);
    std::unique_ptr<State> state_;
};

/// What `lightskin info` prints: the header and a scan of the index (no image decoded).
struct RecordingSummary {
    int version = 0;
    RecordingInfo info;
    std::int64_t frameCount = 0; ///< complete index lines
    bool finished = false;       ///< the end marker was written (not cut off)
    std::int64_t framesWithColour = 0;
    std::int64_t framesWithDepth = 0;
    std::int64_t framesWithGroundTruth = 0;
    double firstTimestampSeconds = 0.0; ///< depth (or colour) timestamps; NaN when absent
    double lastTimestampSeconds = 0.0;
    std::uintmax_t totalBytes = 0; ///< header + index + frame files
};

/// Reads the header and the index of a recording folder. Throws lightskin::Error on a missing,
/// malformed or newer-version header, or a malformed index line (not the last, partial one).
RecordingSummary readRecordingSummary(const std::filesystem::path& folder);

} // namespace lightskin::capture
