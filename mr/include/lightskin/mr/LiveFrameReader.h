#pragma once
// Reads a live source for `lightskin live` and rides out a camera that stops delivering for a
// while (a loose USB cable, a starved bus, a driver hiccup): a stall (capture::SourceStalled, after
// FrameSourceOptions::liveTimeout without a frame) is reported as Result::Stalled with a status
// line naming the cause and how long frames have been missing, and the next call waits again;
// when frames come back the status says so for a while. Only a stall longer than giveUpSeconds,
// or any other error, ends the run (rethrown as lightskin::Error naming the source and the cause).
//
// Not thread-safe; one reader per source. The source must outlive the reader.

#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/RgbdFrame.h>

#include <chrono>
#include <cstdint>
#include <string>

namespace lightskin::mr {

struct LiveFrameReaderOptions {
    /// A stall longer than this (seconds since the last frame) is fatal; <= 0: the first stall is.
    double giveUpSeconds = 60.0;
    /// Frames after a stall during which status() still reports the recovery.
    std::int64_t recoveredFrames = 90;
};

class LiveFrameReader {
public:
    enum class Result { Frame, Stalled, Ended };

    explicit LiveFrameReader(capture::FrameSource& source, const LiveFrameReaderOptions& options = {});

    /// Frame: `out` holds a new frame. Stalled: no frame within the source's live timeout (`out`
    /// untouched; call again to keep waiting). Ended: the source ended. Throws lightskin::Error on
    /// any other source error, or when the stall outlasts giveUpSeconds.
    Result next(RgbdFrame& out);

    /// Empty while frames flow; "camera: no frame for 6.0 s (<cause>); waiting for it" while
    /// stalled; "camera: frames again after a 6.0 s stall" for recoveredFrames frames after.
    const std::string& status() const noexcept { return status_; }
    bool stalled() const noexcept { return stalled_; }
    std::int64_t stalls() const noexcept { return stalls_; } ///< stalls so far (each counted once)

private:
    capture::FrameSource& source_;
    LiveFrameReaderOptions options_;
    std::chrono::steady_clock::time_point lastFrame_;
    bool stalled_ = false;
    std::int64_t stalls_ = 0;
    std::int64_t framesSinceRecovery_ = -1; ///< -1: no recovery to report
    std::string status_;
};

} // namespace lightskin::mr
