#pragma once
// The lightskin recording format (version 1, documented in recordings/README.md): a folder with
//   lightskin-recording.json   header: version, device, intrinsics + distortion of both streams,
//                              depth scale, registration, colour_T_depth, colour encoding
//   frames.jsonl               append-only index, one JSON object per line and frame
//   depth/000000.png ...       16-bit single-channel PNG, raw units (metres = value * depthScale)
//   colour/000000.png ...      8-bit BGR PNG (lossless) or .jpg when jpegColour is set
//
// Crash safety: each frame's image files are written to a temporary name and renamed into place,
// and only then is the frame's index line appended with one write(2). A reader stops at the last
// complete line, so a recording cut off by a crash (or SIGKILL) reads up to its last complete frame.
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

/// Writes a recording. Move-only; the destructor finishes a recording that was not finished.
/// Not thread-safe: one thread writes (Recorder.h puts it behind a queue and a writer thread).
class RecordingWriter {
public:
    /// Creates `folder` (and parents) and writes the header. Throws lightskin::Error when the
    /// folder already holds a recording or files, or cannot be written, or `info` is invalid.
    static RecordingWriter create(const std::filesystem::path& folder, const RecordingInfo& info);

    RecordingWriter(RecordingWriter&&) noexcept;
    RecordingWriter& operator=(RecordingWriter&&) noexcept;
    ~RecordingWriter();

    /// Appends one frame: its depth (CV_16UC1, sizes as in the header's depth intrinsics) and
    /// colour (CV_8UC3 BGR, colour intrinsics' size), timestamps, and groundTruth_world_T_camera
    /// when set. Either image may be empty (not recorded for that frame), not both. The frame's
    /// index field is ignored: frames are numbered 0, 1, 2, ... in write order.
    /// Throws lightskin::Error (folder, frame, cause) when the frame does not match the header
    /// or the disk refuses; the recording stays readable up to the previous frame.
    void write(const RgbdFrame& frame);
    /// Appends the end marker and closes the index. Idempotent.
    void finish();
    std::int64_t framesWritten() const;
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
