#pragma once
// The one pull API for every RGB-D input: lightskin recordings, TUM RGB-D folders, OpenNI2
// devices and .oni files, libfreenect (Kinect v1, also Debian's fakenect replay).
//
//   auto source = capture::openFrameSource("recordings/desk", {});
//   RgbdFrame frame;
//   while (source->next(frame)) { ... }          // false = end of stream
//
// Ownership: the source owns the pixel buffers of the frame it fills and reuses them on the next
// call to next() when the sizes allow; clone() a frame to keep it longer.
// Errors: problems with the input (missing or corrupt file, unplugged device) throw
// lightskin::Error naming the file or URI, the frame index and the cause.
// Threading: a FrameSource is used from one thread at a time.

#include <lightskin/capture/Registration.h>
#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/Pose.h>
#include <lightskin/core/RgbdFrame.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

namespace lightskin::capture {

enum class Pacing : std::uint8_t {
    /// Deliver frames as fast as the consumer pulls them; never drop one (replay, tests). Default.
    AsFastAsPossible,
    /// Honour the recorded timestamps: next() sleeps until a frame is due, and a frame that is
    /// already more than `realtimeLateToleranceSeconds` late (a slow consumer) is skipped without
    /// decoding and counted in framesDropped(). Live sources are paced by the device anyway.
    Realtime,
};

struct FrameSourceOptions {
    Pacing pacing = Pacing::AsFastAsPossible;
    /// Start again at frame 0 after the last frame (recorded sources only). Off by default.
    bool loop = false;
    /// Realtime pacing: how late a frame may be before it is skipped, seconds.
    double realtimeLateToleranceSeconds = 0.1;

    /// TUM layout: largest |t_rgb - t_depth| accepted when pairing the two lists (seconds; the
    /// TUM associate.py default). Also the largest gap to a ground-truth sample used for a pose.
    double maxAssociationSeconds = 0.02;
    /// Overrides the intrinsics a recorded source would otherwise use (TUM sidecar/defaults,
    /// .oni field of view). Applied to both streams.
    std::optional<CameraIntrinsics> intrinsics;
    /// Overrides the depth scale of a TUM folder (metres per unit; TUM default 0.0002 = 1/5000).
    std::optional<double> depthScaleMetres;

    /// Live devices: ask for depth registered to colour (hardware registration). Default on.
    bool registerDepth = true;
    /// Depth that is still not registered to colour after opening (files, fakenect, raw disparity,
    /// devices that cannot register) is registered in software (Registration.h) with the source's
    /// calibration before next() hands it out: frames are then RegisteredToColour. Default on;
    /// `lightskin record` turns it off unless asked (recordings keep the raw depth and the extrinsic).
    bool softwareRegistration = true;
    /// Live devices: a next() that sees no frame for this long throws (device gone).
    std::chrono::milliseconds liveTimeout{3000};
    /// .oni playback: a waitForAnyStream timeout this long means end of file.
    std::chrono::milliseconds oniEndOfFileTimeout{500};
};

/// What a source is and what its frames will carry. Filled by the factory before the first frame.
struct FrameSourceInfo {
    std::string kind;       ///< "lightskin-recording", "tum", "openni2", "oni", "freenect"
    std::string uri;        ///< path or URI the source was opened from
    std::string deviceName; ///< camera model or data set name; may be empty
    bool live = false;      ///< a device (cannot seek, never ends by itself)
    CameraIntrinsics colourIntrinsics;
    CameraIntrinsics depthIntrinsics;
    double depthScaleMetres = 0.001;
    DepthRegistration registration = DepthRegistration::RegisteredToColour;
    Pose colour_T_depth; ///< identity when registered
    /// Where the intrinsics and colour_T_depth come from ("device", "recording header", "Kinect v1
    /// defaults (NYU Depth V2)", ...); empty when the source does not say.
    std::string calibrationSource;
    /// Set when this source registers depth in software (FrameSourceOptions::softwareRegistration):
    /// the depth camera's own intrinsics and the extrinsic used. registration, depthIntrinsics and
    /// colour_T_depth above then describe the delivered (registered) frames.
    std::optional<RegistrationCalibration> softwareRegistration;
    bool hasGroundTruth = false; ///< frames carry groundTruth_world_T_camera (where the source has it)
};

/// Thrown by next() of a live source that saw no frame for FrameSourceOptions::liveTimeout
/// (device stalled, unplugged or starved). The source stays usable: a later next() may deliver
/// again (mr::LiveFrameReader waits for that and shows it). Any other Error is fatal.
class SourceStalled : public Error {
public:
    using Error::Error;
};

class FrameSource {
public:
    virtual ~FrameSource();
    FrameSource(const FrameSource&) = delete;
    FrameSource& operator=(const FrameSource&) = delete;

    /// Fills `out` with the next frame and returns true, or returns false at the end of the
    /// stream (never for a live source unless the device stream ends). Reuses out's buffers.
    /// Throws lightskin::Error on bad input or a lost device.
    bool next(RgbdFrame& out);

    /// Number of frames, when known (recordings, TUM, .oni); nullopt for live sources.
    virtual std::optional<std::int64_t> frameCount() const { return std::nullopt; }
    virtual bool canSeek() const noexcept { return false; }
    /// Makes frame `index` the next one delivered. Throws lightskin::Error when the source cannot
    /// seek or the index is outside [0, frameCount()).
    void seek(std::int64_t index);

    const FrameSourceInfo& info() const noexcept { return info_; }
    const FrameSourceOptions& options() const noexcept { return options_; }
    /// Frames handed out by next().
    std::int64_t framesDelivered() const noexcept { return delivered_; }
    /// Frames the source skipped: realtime pacing running late, or frames a device reported
    /// that never reached us (index gaps).
    std::int64_t framesDropped() const noexcept { return dropped_ + deviceDropped(); }

protected:
    FrameSource(FrameSourceInfo info, FrameSourceOptions options);

    /// Sets `out`'s index and the per-stream facts every frame of this source shares (depth
    /// scale, intrinsics, registration, colour_T_depth) from info(), and clears its ground truth.
    void stampFrame(RgbdFrame& out, std::int64_t index) const;

    /// Reads the next frame in order; false at the end. `out.index` must be set.
    virtual bool readNext(RgbdFrame& out) = 0;
    /// Timestamp (seconds) of the next frame readNext() would deliver, without decoding it;
    /// nullopt when unknown. Used by realtime pacing to skip late frames cheaply.
    virtual std::optional<double> peekNextTimestamp() const { return std::nullopt; }
    /// Skips the next frame without decoding (default: readNext into a scratch frame).
    virtual bool skipNext();
    virtual void seekTo(std::int64_t index);
    /// Frames the device reported but we never received.
    virtual std::int64_t deviceDropped() const noexcept { return 0; }

    FrameSourceInfo info_;
    FrameSourceOptions options_;

private:
    std::int64_t delivered_ = 0;
    std::int64_t dropped_ = 0;
    bool paceStarted_ = false;
    double paceFirstTimestamp_ = 0.0;
    std::chrono::steady_clock::time_point paceStart_;
    RgbdFrame skipScratch_;
    // Software registration (enableSoftwareRegistration): the raw depth buffer readNext() fills
    // and the registered one handed out, both reused frame to frame.
    std::optional<DepthRegistrar> registrar_;
    cv::Mat rawDepth_, registeredDepth_;

    /// Switches this source to software registration when its depth is unregistered and it has
    /// colour; updates info(). Called once by openFrameSource().
    void enableSoftwareRegistration();
    friend std::unique_ptr<FrameSource> openFrameSource(const std::string&, const FrameSourceOptions&);
};

/// Opens a source, detecting its kind from `uriOrPath`:
///   - a folder with `lightskin-recording.json`          -> lightskin recording (recordings/README.md)
///   - a folder with `rgb.txt` and `depth.txt`            -> TUM RGB-D layout
///   - a file ending in `.oni`                            -> OpenNI2 playback
///   - `openni2://` (first device) or `openni2://<uri>`   -> live OpenNI2 device
///   - `freenect://<index>`                               -> live Kinect v1 through libfreenect
/// Throws lightskin::Error naming `uriOrPath` when it is none of these or cannot be opened.
std::unique_ptr<FrameSource> openFrameSource(const std::string& uriOrPath, const FrameSourceOptions& options = {});

} // namespace lightskin::capture
