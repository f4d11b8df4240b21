#include <lightskin/capture/Recorder.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <time.h>
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
using Clock = std::chrono::steady_clock;

/// CPU time of the calling thread (what the writer costs, independent of how loaded the machine is).
double threadCpuSeconds() {
    timespec now{};
    ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
    return double(now.tv_sec) + 1e-9 * double(now.tv_nsec);
}

/// 1 ms bins up to 10 s: preallocated, so the writer records a latency without allocating.
constexpr std::size_t kLatencyBins = 10000;

/// Upper edge (ms) of the bin holding the q-quantile of `histogram`; 0 when empty.
double percentileMs(const std::vector<std::uint32_t>& histogram, std::int64_t total, double q) {
    if (total <= 0) return 0.0;
    const auto rank = std::int64_t(std::ceil(q * double(total)));
    std::int64_t seen = 0;
    for (std::size_t bin = 0; bin < histogram.size(); ++bin) {
        seen += histogram[bin];
        if (seen >= rank) return double(bin + 1);
    }
    return double(histogram.size());
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
    std::vector<Clock::time_point> pushedAt; ///< per slot
    std::vector<std::uint32_t> latencyHistogram = std::vector<std::uint32_t>(kLatencyBins, 0);
    mutable std::mutex mutex;
    std::condition_variable wake;
    std::thread thread;

    explicit Impl(RecordingWriter w, std::size_t capacity)
        : writer(std::move(w))
        , slots(capacity)
        , pushedAt(capacity) {}

    /// `stats` with the latency percentiles filled in; call with `mutex` held.
    RecorderStats snapshot() const {
        RecorderStats copy = stats;
        copy.queued = std::int64_t(count);
        copy.waitingForSync = writerWaiting;
        copy.dropped = stats.pushed - stats.written - writerWaiting - copy.queued;
        copy.writerCpuMsPerFrame = latencySamples > 0 ? 1000.0 * writerCpuSeconds / double(latencySamples) : 0.0;
        copy.writeLatencyP50Ms = percentileMs(latencyHistogram, latencySamples, 0.50);
        copy.writeLatencyP95Ms = percentileMs(latencyHistogram, latencySamples, 0.95);
        copy.writeLatencyP99Ms = percentileMs(latencyHistogram, latencySamples, 0.99);
        return copy;
    }

    // The writer's counters, copied under `mutex` after each writer call (the writer itself is the
    // writer thread's alone). written = listed; a frame the writer took but whose sync failed is in
    // neither, so dropped = pushed - written - waiting - queued covers it with the refused ones.
    std::int64_t writerWaiting = 0, latencySamples = 0;
    double writerCpuSeconds = 0.0; ///< CPU time of the writer thread inside write()

    void takeWriterCounts() {
        stats.written = writer.framesListed();
        writerWaiting = writer.framesWritten() - stats.written;
    }

    void noteError(const std::string& error) {
        if (stats.firstError.empty()) stats.firstError = error;
        log::error("recorder: " + error);
    }

    void run() {
        for (;;) {
            std::unique_lock lock(mutex);
            // Wakes at least every 100 ms while idle, so frames waiting for a sync get listed within
            // syncEverySeconds + 0.1 s even when the source pauses.
            const bool woken =
                wake.wait_for(lock, std::chrono::milliseconds(100), [&] { return count > 0 || stopping; });
            if (!woken) {
                lock.unlock();
                std::string error;
                try {
                    writer.syncIfDue();
                } catch (const std::exception& e) {
                    error = e.what();
                }
                lock.lock();
                takeWriterCounts();
                if (!error.empty()) noteError("frames not listed: " + error);
                continue;
            }
            if (count == 0) return; // stopping and drained
            RgbdFrame& frame = slots[head];
            lock.unlock();
            std::string error;
            const double cpuBefore = threadCpuSeconds();
            try {
                writer.write(frame);
            } catch (const std::exception& e) {
                error = e.what(); // the frame failed, or the sync it triggered did (losing the batch)
            }
            const double cpuSeconds = threadCpuSeconds() - cpuBefore;
            const double latencyMs = std::chrono::duration<double, std::milli>(Clock::now() - pushedAt[head]).count();
            lock.lock();
            writerCpuSeconds += cpuSeconds;
            if (error.empty()) {
                ++latencySamples;
                ++latencyHistogram[std::min(std::size_t(latencyMs), kLatencyBins - 1)];
                stats.writeLatencyMaxMs = std::max(stats.writeLatencyMaxMs, latencyMs);
            } else {
                noteError("frame not written: " + error);
            }
            takeWriterCounts();
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
        if (s.count == s.slots.size()) {
            ++s.stats.pushed; // counted as dropped by snapshot()
            return false;
        }
        slot = s.tail;
    }
    s.pushedAt[slot] = Clock::now();
    copyFrameInto(frame, s.slots[slot]);
    {
        std::lock_guard lock(s.mutex);
        // Counted pushed only now, with the frame queued: snapshot() derives dropped from both.
        ++s.stats.pushed;
        s.tail = (s.tail + 1) % s.slots.size();
        ++s.count;
        s.stats.queueHighWater = std::max(s.stats.queueHighWater, std::int64_t(s.count));
    }
    s.wake.notify_one();
    return true;
}

RecorderStats Recorder::finish() {
    Impl& s = *impl_;
    {
        std::lock_guard lock(s.mutex);
        if (s.finished) return s.snapshot();
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
    s.takeWriterCounts();
    s.finished = true;
    return s.snapshot();
}

RecorderStats Recorder::stats() const {
    std::lock_guard lock(impl_->mutex);
    return impl_->snapshot();
}

} // namespace lightskin::capture
