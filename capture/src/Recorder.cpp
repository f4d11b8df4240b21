#include <lightskin/capture/Recorder.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>

#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

namespace lightskin::capture {

namespace {
void copyFrameInto(const RgbdFrame& from, RgbdFrame& to) {
    // copyTo keeps the slot's buffers when the sizes match: no allocation in steady state.
    if (from.hasColour())
        from.colour.copyTo(to.colour);
    else
        to.colour.release();
    if (from.hasDepth())
        from.depth.copyTo(to.depth);
    else
        to.depth.release();
    to.index = from.index;
    to.depthScaleMetres = from.depthScaleMetres;
    to.colourTimestampSeconds = from.colourTimestampSeconds;
    to.depthTimestampSeconds = from.depthTimestampSeconds;
    to.colourIntrinsics = from.colourIntrinsics;
    to.depthIntrinsics = from.depthIntrinsics;
    to.registration = from.registration;
    to.colour_T_depth = from.colour_T_depth;
    to.groundTruth_world_T_camera = from.groundTruth_world_T_camera;
}
} // namespace

struct Recorder::Impl {
    RecordingWriter writer;
    std::vector<RgbdFrame> slots;
    // Single producer: the producer fills slot `tail` outside the lock (the writer never touches
    // it while count < capacity) and publishes it under the lock.
    std::size_t head = 0, tail = 0, count = 0;
    bool stopping = false, finished = false;
    RecorderStats stats;
    mutable std::mutex mutex;
    std::condition_variable wake;
    std::thread thread;

    explicit Impl(RecordingWriter w, std::size_t capacity)
        : writer(std::move(w))
        , slots(capacity) {}

    void run() {
        for (;;) {
            std::unique_lock lock(mutex);
            wake.wait(lock, [&] { return count > 0 || stopping; });
            if (count == 0) return; // stopping and drained
            RgbdFrame& frame = slots[head];
            lock.unlock();
            std::string error;
            try {
                writer.write(frame);
            } catch (const std::exception& e) {
                error = e.what();
            }
            lock.lock();
            if (error.empty())
                ++stats.written;
            else {
                ++stats.dropped;
                if (stats.firstError.empty()) stats.firstError = error;
                log::error("recorder: frame not written: " + error);
            }
            head = (head + 1) % slots.size();
            --count;
        }
    }
};

Recorder::Recorder(std::unique_ptr<Impl> impl)
    : impl_(std::move(impl)) {}

std::unique_ptr<Recorder> Recorder::start(RecordingWriter writer, const RecorderOptions& options) {
    LIGHTSKIN_ASSERT(options.queueCapacity > 0, "the queue needs at least one slot");
    auto recorder =
        std::unique_ptr<Recorder>(new Recorder(std::make_unique<Impl>(std::move(writer), options.queueCapacity)));
    Impl* impl = recorder->impl_.get();
    impl->thread = std::thread([impl] { impl->run(); });
    return recorder;
}

Recorder::~Recorder() {
    if (impl_) finish();
}

bool Recorder::push(const RgbdFrame& frame) {
    Impl& s = *impl_;
    std::size_t slot = 0;
    {
        std::lock_guard lock(s.mutex);
        LIGHTSKIN_ASSERT(!s.stopping, "push() after finish()");
        ++s.stats.pushed;
        if (s.count == s.slots.size()) {
            ++s.stats.dropped;
            return false;
        }
        slot = s.tail;
    }
    copyFrameInto(frame, s.slots[slot]);
    {
        std::lock_guard lock(s.mutex);
        s.tail = (s.tail + 1) % s.slots.size();
        ++s.count;
    }
    s.wake.notify_one();
    return true;
}

RecorderStats Recorder::finish() {
    Impl& s = *impl_;
    {
        std::lock_guard lock(s.mutex);
        if (s.finished) return s.stats;
        s.stopping = true;
    }
    s.wake.notify_one();
    if (s.thread.joinable()) s.thread.join();
    std::lock_guard lock(s.mutex);
    try {
        s.writer.finish();
    } catch (const std::exception& e) {
        if (s.stats.firstError.empty()) s.stats.firstError = e.what();
    }
    s.finished = true;
    return s.stats;
}

RecorderStats Recorder::stats() const {
    std::lock_guard lock(impl_->mutex);
    RecorderStats copy = impl_->stats;
    copy.queued = std::int64_t(impl_->count);
    return copy;
}

} // namespace lightskin::capture
