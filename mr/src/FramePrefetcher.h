#pragma once
// Session's prefetch (SessionOptions::prefetch): a worker thread reads frame n+1 from the source and runs
// its CPU-only front (FramePipeline::prepare: depth filter, pose) while the caller's thread renders frame n
// (VALs, GI, shading and composite on GL). A ring of kSlots frames sized on first use: no allocation per
// frame; the worker runs at most kSlots - 1 frames ahead of the frame the caller holds. wait() shows the
// caller the frame after its current one (NextFrame: the pipeline's GI ahead, FramePipeline.h).
//
// Determinism: the worker prepares the frames in source order, one at a time, with the pipeline's own
// filter and tracker, exactly as FramePipeline::process would: the images equal the sequential run's bit
// for bit (tests/mr/SessionGLTest.cpp). An exception of the source or of prepare() is kept with its frame
// and rethrown by next() for that frame (the frames before it are delivered first), as in the sequential run.

#include <lightskin/capture/FrameSource.h>
#include <lightskin/mr/FramePipeline.h>

#include <array>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>

namespace lightskin::mr {

class FramePrefetcher final : public NextFrame {
public:
    /// A frame read and prepared by the worker; owned by the prefetcher, valid until the next next().
    struct Slot {
        RgbdFrame frame; ///< a deep copy of the source's frame (sources may reuse their buffers)
        PreparedFrame prepared;
        std::exception_ptr error; ///< reading or preparing this frame failed (rethrown by next())
        bool end = false;         ///< the source had no more frames
    };

    /// Starts the worker. `source` and `pipeline` must outlive the prefetcher, and while it lives only its
    /// worker calls source.next() and pipeline.prepare().
    FramePrefetcher(capture::FrameSource& source, FramePipeline& pipeline);
    /// Stops the worker (it finishes the frame it is reading, if any) and joins it.
    ~FramePrefetcher();
    FramePrefetcher(const FramePrefetcher&) = delete;
    FramePrefetcher& operator=(const FramePrefetcher&) = delete;

    /// Hands back the slot of the previous call and returns the next prepared frame, waiting for it;
    /// nullptr at the source's end. Rethrows the frame's exception (the prefetcher then stays at it).
    const Slot* next();
    /// NextFrame: the frame after the one the last next() returned, waiting until the worker has prepared
    /// it; false at the source's end or when reading or preparing it failed (next() rethrows that at its frame).
    bool wait(const RgbdFrame*& frame, const PreparedFrame*& prepared) override;

private:
    // The frame being rendered, the next one (which wait() hands out while that renders) and the one
    // being prepared: the worker keeps busy while the caller looks one frame ahead.
    static constexpr std::size_t kSlots = 3;
    void run();

    capture::FrameSource& source_;
    FramePipeline& pipeline_;
    std::array<Slot, kSlots> slots_;
    RgbdFrame scratch_; // what the source hands out, copied into a slot
    std::mutex mutex_;
    std::condition_variable changed_;
    std::uint64_t produced_ = 0; // slots filled by the worker (frame k in slots_[k % kSlots])
    std::uint64_t consumed_ = 0; // slots handed to the caller
    std::uint64_t released_ = 0; // slots the caller gave back
    bool stop_ = false;
    std::thread worker_; // last: starts after everything above is constructed
};

} // namespace lightskin::mr
