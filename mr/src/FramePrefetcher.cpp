#include "FramePrefetcher.h"

namespace lightskin::mr {

namespace {

// A deep copy into `out`'s buffers: copyTo reallocates only when the size or type changes.
void copyFrameInto(const RgbdFrame& in, RgbdFrame& out) {
    out.index = in.index;
    if (in.colour.empty())
        out.colour.release();
    else
        in.colour.copyTo(out.colour);
    if (in.depth.empty())
        out.depth.release();
    else
        in.depth.copyTo(out.depth);
    out.depthScaleMetres = in.depthScaleMetres;
    out.colourTimestampSeconds = in.colourTimestampSeconds;
    out.depthTimestampSeconds = in.depthTimestampSeconds;
    out.colourIntrinsics = in.colourIntrinsics;
    out.depthIntrinsics = in.depthIntrinsics;
    out.registration = in.registration;
    out.colour_T_depth = in.colour_T_depth;
    out.groundTruth_world_T_camera = in.groundTruth_world_T_camera;
}

} // namespace

FramePrefetcher::FramePrefetcher(capture::FrameSource& source, FramePipeline& pipeline)
    : source_(source)
    , pipeline_(pipeline)
    , worker_([this] { run(); }) {}

FramePrefetcher::~FramePrefetcher() {
    {
        const std::lock_guard lock(mutex_);
        stop_ = true;
    }
    changed_.notify_all();
    worker_.join();
}

void FramePrefetcher::run() {
    for (std::uint64_t k = 0;; ++k) {
        {
            std::unique_lock lock(mutex_);
            changed_.wait(lock, [&] { return stop_ || k - released_ < kSlots; }); // slot k % kSlots is free
            if (stop_) return;
        }
        // Outside the lock: the caller only reads slots below produced_, this one is not among them.
        Slot& slot = slots_[k % kSlots];
        slot.error = nullptr;
        slot.end = false;
        try {
            if (source_.next(scratch_)) {
                copyFrameInto(scratch_, slot.frame);
                pipeline_.prepare(slot.frame, slot.prepared);
            } else {
                slot.end = true;
            }
        } catch (...) {
            slot.error = std::current_exception();
        }
        const bool last = slot.end || slot.error != nullptr;
        {
            const std::lock_guard lock(mutex_);
            produced_ = k + 1;
        }
        changed_.notify_all();
        if (last) return; // next() stays at this slot
    }
}

const FramePrefetcher::Slot* FramePrefetcher::next() {
    std::unique_lock lock(mutex_);
    if (released_ < consumed_) { // the caller is done with the previous frame
        released_ = consumed_;
        lock.unlock();
        changed_.notify_all();
        lock.lock();
    }
    changed_.wait(lock, [&] { return produced_ > consumed_; });
    const Slot& slot = slots_[consumed_ % kSlots];
    if (slot.error) std::rethrow_exception(slot.error); // stays at this frame: every later next() rethrows
    if (slot.end) return nullptr;
    ++consumed_;
    return &slot;
}

bool FramePrefetcher::wait(const RgbdFrame*& frame, const PreparedFrame*& prepared) {
    std::unique_lock lock(mutex_);
    if (consumed_ == 0) return false; // no current frame yet
    // Slot consumed_ is not released, so the worker does not write it once produced (k - released_ < kSlots).
    changed_.wait(lock, [&] { return produced_ > consumed_; });
    const Slot& slot = slots_[consumed_ % kSlots];
    if (slot.error || slot.end) return false;
    frame = &slot.frame;
    prepared = &slot.prepared;
    return true;
}

} // namespace lightskin::mr
