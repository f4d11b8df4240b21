// Recorder under load, the long run: a paced synthetic 640x480 RGB-D source at
// 30 fps into capture::Recorder for SECONDS while BUSY threads spin (default 1: "the other core
// saturated" on a 2-core machine), then the recorder's figures: frames pushed/written/dropped,
// queue high-water mark, write-latency percentiles. Exit status 1 when a frame was lost.
//   build/capture/lightskin_bench_recorder_load OUTPUT_FOLDER [SECONDS=600] [BUSY=1] [QUEUE=30]
// scripts/recorder_load.sh runs the 10-minute version. The short CI check is
// tests/capture/RecorderLoadTest.cpp (bookkeeping only, no timing assertion).
#include <lightskin/capture/Recorder.h>
#include <lightskin/capture/Recording.h>
#include <lightskin/core/Error.h>

#include <opencv2/core.hpp>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

namespace {

/// Camera-like content (smooth ramps, mild noise), so PNG costs what it costs on real frames.
lightskin::RgbdFrame cameraLikeFrame(const lightskin::capture::RecordingInfo& info, std::uint64_t seed) {
    lightskin::RgbdFrame frame;
    frame.depth.create(480, 640, CV_16UC1);
    frame.colour.create(480, 640, CV_8UC3);
    cv::RNG rng(seed);
    for (int v = 0; v < 480; ++v)
        for (int u = 0; u < 640; ++u) {
            const double noise = rng.gaussian(3.0);
            frame.depth.at<std::uint16_t>(v, u) = cv::saturate_cast<std::uint16_t>(1000.0 + 2.0 * u + v + noise);
            frame.colour.at<cv::Vec3b>(v, u) =
                cv::Vec3b(cv::saturate_cast<uchar>(u / 3), cv::saturate_cast<uchar>(v / 2),
                          cv::saturate_cast<uchar>(128.0 + noise));
        }
    frame.depthScaleMetres = info.depthScaleMetres;
    frame.colourIntrinsics = info.colourIntrinsics;
    frame.depthIntrinsics = info.depthIntrinsics;
    return frame;
}

} // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s OUTPUT_FOLDER [SECONDS=600] [BUSY=1] [QUEUE=30]\n", argv[0]);
        return 2;
    }
    const std::string folder = argv[1];
    const double seconds = argc > 2 ? std::atof(argv[2]) : 600.0;
    const int busyThreads = argc > 3 ? std::atoi(argv[3]) : 1;
    const auto queue = static_cast<std::size_t>(argc > 4 ? std::atoi(argv[4]) : 30);
    try {
        lightskin::capture::RecordingInfo info;
        info.deviceName = "lightskin_bench_recorder_load";
        info.colourIntrinsics = info.depthIntrinsics = lightskin::CameraIntrinsics::kinectV1Default();
        std::atomic<bool> stop{false};
        std::vector<std::thread> busy;
        for (int i = 0; i < busyThreads; ++i)
            busy.emplace_back([&] {
                volatile double sink = 0.0;
                while (!stop.load(std::memory_order_relaxed)) sink = sink + 1.0;
            });
        auto recorder =
            lightskin::capture::Recorder::start(lightskin::capture::RecordingWriter::create(folder, info), {queue});
        const lightskin::RgbdFrame frames[2] = {cameraLikeFrame(info, 1), cameraLikeFrame(info, 2)};
        lightskin::RgbdFrame frame;
        const auto frameCount = static_cast<std::int64_t>(seconds * 30.0);
        const auto start = std::chrono::steady_clock::now();
        for (std::int64_t i = 0; i < frameCount; ++i) {
            std::this_thread::sleep_until(start + std::chrono::microseconds(33333) * i);
            frames[i % 2].colour.copyTo(frame.colour); // reuses frame's buffers after the first
            frames[i % 2].depth.copyTo(frame.depth);
            frame.depthScaleMetres = info.depthScaleMetres;
            frame.colourIntrinsics = info.colourIntrinsics;
            frame.depthIntrinsics = info.depthIntrinsics;
            frame.colourTimestampSeconds = frame.depthTimestampSeconds = double(i) / 30.0;
            recorder->push(frame);
        }
        const auto stats = recorder->finish();
        stop = true;
        for (auto& thread : busy) thread.join();
        std::printf("%lld frames (%.0f s at 30 fps, 640x480, %d busy threads, queue %zu): written %lld, dropped %lld, "
                    "queue high-water %lld, write latency p50 %.0f ms, p95 %.0f ms, p99 %.0f ms, max %.1f ms, "
                    "writer CPU %.1f ms per frame%s%s\n",
                    static_cast<long long>(frameCount), seconds, busyThreads, queue,
                    static_cast<long long>(stats.written), static_cast<long long>(stats.dropped),
                    static_cast<long long>(stats.queueHighWater), stats.writeLatencyP50Ms, stats.writeLatencyP95Ms,
                    stats.writeLatencyP99Ms, stats.writeLatencyMaxMs, stats.writerCpuMsPerFrame,
                    stats.firstError.empty() ? "" : "; ", stats.firstError.c_str());
        return stats.dropped == 0 && stats.written == frameCount ? 0 : 1;
    } catch (const lightskin::Error& error) {
        std::fprintf(stderr, "%s\n", error.what());
        return 1;
    }
}
