// How fast the .oni player delivers a whole recording (Google Benchmark), as fast as possible
// against realtime pacing, side by side ("as fast as possible, the end detected without waiting a
// frame period"): a timing claim, so a benchmark and not a test.
//   build/capture/lightskin_bench_oni_read [--benchmark_repetitions=3]
// Input: tests/data/oni-kinect-v1/3dj_test.oni (12 frames, 30 fps, 640x480 depth + colour).
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/RgbdFrame.h>

#include <benchmark/benchmark.h>

namespace {

constexpr const char* kOni = LIGHTSKIN_SOURCE_DIR "/tests/data/oni-kinect-v1/3dj_test.oni";

/// Opens the file once (OpenNI2 start-up is not what is measured), then reads it to the end per
/// iteration. Reports frames per pass and the recording's own duration for the ratio.
void readAll(benchmark::State& state, lightskin::capture::Pacing pacing) {
    lightskin::capture::FrameSourceOptions options;
    options.pacing = pacing;
    auto source = lightskin::capture::openFrameSource(kOni, options);
    lightskin::RgbdFrame frame;
    std::int64_t frames = 0;
    for (auto _ : state) {
        source->seek(0);
        frames = 0;
        while (source->next(frame)) ++frames;
        benchmark::DoNotOptimize(frame.depth.data);
    }
    state.counters["frames"] = double(frames);
    state.counters["recorded_ms"] = 1000.0 * double(frames - 1) / 30.0; // 30 fps, first to last frame
}

void BM_OniAsFastAsPossible(benchmark::State& state) { readAll(state, lightskin::capture::Pacing::AsFastAsPossible); }
BENCHMARK(BM_OniAsFastAsPossible)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_OniRealtime(benchmark::State& state) { readAll(state, lightskin::capture::Pacing::Realtime); }
BENCHMARK(BM_OniRealtime)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

} // namespace

BENCHMARK_MAIN();
