#pragma once
// Records frames without making capture wait for the disk: push() copies a frame into one of a
// fixed number of preallocated slots (no allocation once the slots have their sizes) and returns
// at once; a background thread encodes and writes the slots through a RecordingWriter (atomic
// rename per file; index lines in durable batches, RecordingDurability in Recording.h, given to
// RecordingWriter::create). When every slot is taken the frame is not queued and is counted as
// dropped; a frame the writer fails to write or to sync is counted as dropped too. So after
// finish() every pushed frame is either listed in the recording or in `dropped`.
//
// Threading: push() from one producer thread; stats() from any thread.

#include <lightskin/capture/Recording.h>
#include <lightskin/core/RgbdFrame.h>

#include <cstdint>
#include <memory>
#include <string>

namespace lightskin::capture {

struct RecorderOptions {
    /// Frames that may wait for the disk. 30 = one second at 30 fps (about 45 MB at 640x480).
    std::size_t queueCapacity = 30;
};

struct RecorderStats {
    std::int64_t pushed = 0;         ///< frames offered to push()
    std::int64_t written = 0;        ///< frames listed in the recording's index (durable per its policy)
    std::int64_t dropped = 0;        ///< queue full, write failed or sync failed
    std::int64_t queued = 0;         ///< waiting for the writer right now
    std::int64_t waitingForSync = 0; ///< written by the writer, listed at its next sync (0 after finish())
    std::int64_t queueHighWater = 0; ///< most frames waiting at once (<= queueCapacity); drops start there
    /// Write latency of the written frames: push() to the frame's files renamed into place
    /// (listing follows at the writer's next sync, within RecordingDurability's interval), milliseconds. From a
    /// histogram of 1 ms bins (each percentile is the upper edge of its bin; beyond 10 s all land in the last bin); max
    /// is exact. 0 when nothing was written.
    double writeLatencyP50Ms = 0.0, writeLatencyP95Ms = 0.0, writeLatencyP99Ms = 0.0, writeLatencyMaxMs = 0.0;
    /// CPU time the writer thread spent per written frame (encoding, writing, its share of the
    /// syncs), milliseconds: 1000 / 30 = 33 ms is a whole core at 30 fps. 0 when nothing was written.
    double writerCpuMsPerFrame = 0.0;
    std::string firstError; ///< the first write error (empty when none)
};

class Recorder {
public:
    /// Takes over `writer` and starts the writer thread.
    static std::unique_ptr<Recorder> start(RecordingWriter writer, const RecorderOptions& options = {});
    ~Recorder(); ///< finish()es when still running
    Recorder(const Recorder&) = delete;
    Recorder& operator=(const Recorder&) = delete;

    /// Queues a copy of `frame`; false when the queue is full (the frame is dropped and counted).
    bool push(const RgbdFrame& frame);
    /// Writes what is queued, finishes the recording and stops the thread. Idempotent.
    RecorderStats finish();
    RecorderStats stats() const;

private:
    struct Impl;
    explicit Recorder(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::capture
