// Helper process of capture_recorder_kill_test: records paced synthetic frames through
// capture::Recorder (what `lightskin record` uses) until it is killed, and reports its progress on
// stdout, one line per frame, flushed: "created" once the writer exists, then
// "pushed P listed L dropped D" after each push (L = frames the recorder reports listed, i.e.
// synced to the index). Usage: capture_recorder_kill_helper FOLDER SYNC_FRAMES QUEUE PERIOD_MS
#include "CaptureTestUtil.h"

#include <lightskin/capture/Recorder.h>
#include <lightskin/capture/Recording.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>

int main(int argc, char** argv) {
    using namespace lightskin;
    if (argc != 5) {
        std::fprintf(stderr, "usage: %s FOLDER SYNC_FRAMES QUEUE PERIOD_MS\n", argv[0]);
        return 2;
    }
    const auto info = test::smallRecordingInfo(32, 24);
    capture::RecordingDurability durability;
    durability.syncEveryFrames = std::atoll(argv[2]);
    durability.syncEverySeconds = 60.0; // only the frame count triggers syncs: the bound is exact
    capture::RecorderOptions options;
    options.queueCapacity = std::size_t(std::atoll(argv[3]));
    const auto period = std::chrono::milliseconds(std::atoi(argv[4]));
    auto recorder = capture::Recorder::start(capture::RecordingWriter::create(argv[1], info, durability), options);
    std::printf("created\n");
    std::fflush(stdout);
    auto next = std::chrono::steady_clock::now();
    for (std::uint32_t i = 0; i < 1000000; ++i) {
        recorder->push(test::syntheticFrame(info, i));
        const auto stats = recorder->stats();
        std::printf("pushed %u listed %lld dropped %lld\n", i + 1, static_cast<long long>(stats.written),
                    static_cast<long long>(stats.dropped));
        std::fflush(stdout);
        next += period;
        std::this_thread::sleep_until(next);
    }
    recorder->finish();
    return 0;
}
