// Recorder under load (short CI version; the 10-minute run is
// capture/bench/RecorderLoadBenchmark.cpp, scripts/recorder_load.sh). A paced synthetic source at
// 30 fps, 640x480 RGB-D, while another thread keeps a core busy. Asserted: the bookkeeping (every
// frame written or counted as dropped, the high-water mark within the queue and at its capacity
// whenever a frame was dropped, ordered latency percentiles) and that every written frame reads
// back. Not asserted: zero drops, which depends on the machine's load (timing; the
// benchmark reports it).
#include "CaptureTestUtil.h"
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/capture/Recorder.h>
#include <lightskin/capture/Recording.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>

namespace lightskin::test {
namespace {

void expectConsistent(const capture::RecorderStats& stats, std::int64_t pushed, std::size_t capacity) {
    EXPECT_EQ(stats.pushed, pushed);
    EXPECT_EQ(stats.written + stats.dropped, pushed);
    EXPECT_EQ(stats.queued, 0);
    EXPECT_GE(stats.queueHighWater, 1);
    EXPECT_LE(stats.queueHighWater, std::int64_t(capacity));
    // Frames are dropped at push() only when every slot is taken (no write errors here).
    if (stats.dropped > 0) {
        EXPECT_EQ(stats.queueHighWater, std::int64_t(capacity));
    }
    EXPECT_TRUE(stats.firstError.empty()) << stats.firstError;
    // Percentiles are upper edges of 1 ms bins: ordered, >= 1 ms, and at most 1 ms above the exact max.
    EXPECT_GE(stats.writeLatencyP50Ms, 1.0);
    EXPECT_LE(stats.writeLatencyP50Ms, stats.writeLatencyP95Ms);
    EXPECT_LE(stats.writeLatencyP95Ms, stats.writeLatencyP99Ms);
    EXPECT_LE(stats.writeLatencyP99Ms, std::floor(stats.writeLatencyMaxMs) + 1.0);
    EXPECT_GT(stats.writeLatencyMaxMs, 0.0);
}

void expectReadsBack(const std::filesystem::path& folder, std::int64_t written) {
    auto source = capture::openFrameSource(folder.string());
    ASSERT_EQ(source->frameCount(), written);
    RgbdFrame frame;
    std::int64_t read = 0;
    while (source->next(frame)) ++read;
    EXPECT_EQ(read, written);
}

/// A camera-like VGA frame: smooth depth and colour ramps with mild noise, which PNG compresses
/// as it does real frames (syntheticFrame's uniform noise is the incompressible worst case).
RgbdFrame cameraLikeFrame(const capture::RecordingInfo& info, std::uint32_t seed) {
    RgbdFrame frame = syntheticFrame(info, seed);
    cv::Mat noise(frame.depth.size(), CV_16SC1);
    cv::RNG rng(seed);
    rng.fill(noise, cv::RNG::NORMAL, 0, 3);
    for (int v = 0; v < frame.depth.rows; ++v)
        for (int u = 0; u < frame.depth.cols; ++u) {
            frame.depth.at<std::uint16_t>(v, u) =
                cv::saturate_cast<std::uint16_t>(1000 + 2 * u + v + noise.at<short>(v, u));
            frame.colour.at<cv::Vec3b>(v, u) =
                cv::Vec3b(cv::saturate_cast<uchar>(u / 3), cv::saturate_cast<uchar>(v / 2),
                          cv::saturate_cast<uchar>(128 + noise.at<short>(v, u)));
        }
    return frame;
}

TEST(RecorderLoadTest, OneFrameAtATimeHasHighWaterOne) {
    const auto folder = scratchDir("recorder_highwater_one") / "rec";
    const auto info = smallRecordingInfo(64, 48);
    auto recorder = capture::Recorder::start(capture::RecordingWriter::create(folder, info), {8});
    constexpr int kFrames = 10;
    for (int i = 0; i < kFrames; ++i) {
        ASSERT_TRUE(recorder->push(syntheticFrame(info, std::uint32_t(i))));
        // Wait (bounded) until the writer has it: the queue never holds two frames.
        for (int wait = 0; wait < 30000 && recorder->stats().written < i + 1; ++wait)
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    const auto stats = recorder->finish();
    expectConsistent(stats, kFrames, 8);
    EXPECT_EQ(stats.queueHighWater, 1);
    EXPECT_EQ(stats.written, kFrames);
}

TEST(RecorderLoadTest, BurstIntoATinyQueueDropsOnlyWhenFull) {
    // 20 VGA frames pushed at once into 2 slots: the writer (~10+ ms per frame for the two PNGs)
    // cannot keep up with pushes (~0.3 ms each), so frames are dropped, and only at a full queue.
    const auto folder = scratchDir("recorder_burst") / "rec";
    const auto info = smallRecordingInfo(640, 480);
    auto recorder = capture::Recorder::start(capture::RecordingWriter::create(folder, info), {2});
    const RgbdFrame frame = syntheticFrame(info, 1);
    for (int i = 0; i < 20; ++i) recorder->push(frame);
    const auto stats = recorder->finish();
    expectConsistent(stats, 20, 2);
    expectReadsBack(folder, stats.written);
}

TEST(RecorderLoadTest, PacedVgaAt30FpsWithABusyCore) {
    const auto folder = scratchDir("recorder_paced") / "rec";
    const auto info = smallRecordingInfo(640, 480);
    constexpr std::size_t kCapacity = 30;
    constexpr int kFrames = 30; // 1 s at 30 fps
    std::atomic<bool> stop{false};
    std::thread busy([&] {
        volatile double sink = 0.0;
        while (!stop.load(std::memory_order_relaxed)) sink = sink + 1.0;
    });
    auto recorder = capture::Recorder::start(capture::RecordingWriter::create(folder, info), {kCapacity});
    // Two frames alternate: pushing copies pixels, so the content does not need to change.
    const RgbdFrame frames[2] = {cameraLikeFrame(info, 1), cameraLikeFrame(info, 2)};
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < kFrames; ++i) {
        std::this_thread::sleep_until(start + std::chrono::microseconds(33333) * i);
        RgbdFrame frame = frames[i % 2];
        frame.colourTimestampSeconds = frame.depthTimestampSeconds = i / 30.0;
        recorder->push(frame);
    }
    const auto stats = recorder->finish();
    stop = true;
    busy.join();
    expectConsistent(stats, kFrames, kCapacity);
    expectReadsBack(folder, stats.written);
    std::printf("paced 30 fps VGA, %d frames: written %lld, dropped %lld, queue high-water %lld/%zu, "
                "write latency p50 %.0f ms, p95 %.0f ms, p99 %.0f ms, max %.1f ms\n",
                kFrames, static_cast<long long>(stats.written), static_cast<long long>(stats.dropped),
                static_cast<long long>(stats.queueHighWater), kCapacity, stats.writeLatencyP50Ms,
                stats.writeLatencyP95Ms, stats.writeLatencyP99Ms, stats.writeLatencyMaxMs);
}

} // namespace
} // namespace lightskin::test
