// Cost of BilateralDepthFilter::filterInto per 640x480 depth frame (Google Benchmark).
//   build/capture/lightskin_bench_depth_filter [--benchmark_repetitions=5]
// Inputs: a synthetic noisy scene with 10 % missing pixels, and a real TUM fr2 depth frame
// (tests/data/tum-fr2-desk/1_depth.png) when the source tree is present. BM_BilateralOni: both
// implementations (Simd, OpenCv) on the registered depth of the Kinect v1 .oni's frames, as the
// replay filters them, with the process's CPU time (OpenCV's worker threads included).
#include <lightskin/capture/DepthFilter.h>
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/RgbdFrame.h>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace {

cv::Mat syntheticDepth() {
    cv::Mat depth(480, 640, CV_16UC1);
    cv::RNG rng(1);
    for (int v = 0; v < 480; ++v)
        for (int u = 0; u < 640; ++u) {
            const double z = (u < 320 ? 1500.0 : 2500.0) + 0.5 * v + rng.gaussian(10.0);
            depth.at<std::uint16_t>(v, u) = rng.uniform(0.0, 1.0) < 0.1 ? 0 : static_cast<std::uint16_t>(z);
        }
    return depth;
}

void run(benchmark::State& state, const cv::Mat& depth, double scale) {
    lightskin::capture::BilateralDepthFilter filter;
    cv::Mat out;
    filter.filterInto(depth, scale, out); // sizes the buffers once
    for (auto _ : state) {
        filter.filterInto(depth, scale, out);
        benchmark::DoNotOptimize(out.data);
    }
    state.SetLabel(std::to_string(depth.cols) + "x" + std::to_string(depth.rows) + ", " +
                   std::to_string(cv::getNumThreads()) + " OpenCV threads");
}

void BM_BilateralSynthetic(benchmark::State& state) { run(state, syntheticDepth(), 0.001); }
BENCHMARK(BM_BilateralSynthetic)->Unit(benchmark::kMillisecond);

void BM_BilateralTumFr2(benchmark::State& state) {
    const cv::Mat depth = cv::imread(LIGHTSKIN_SOURCE_DIR "/tests/data/tum-fr2-desk/1_depth.png", cv::IMREAD_UNCHANGED);
    if (depth.empty()) {
        state.SkipWithError("tests/data/tum-fr2-desk/1_depth.png not found");
        return;
    }
    run(state, depth, 1.0 / 5000.0);
}
BENCHMARK(BM_BilateralTumFr2)->Unit(benchmark::kMillisecond);

void BM_BilateralSingleThread(benchmark::State& state) {
    const int threads = cv::getNumThreads();
    cv::setNumThreads(1);
    run(state, syntheticDepth(), 0.001);
    cv::setNumThreads(threads);
}
BENCHMARK(BM_BilateralSingleThread)->Unit(benchmark::kMillisecond);

/// The .oni's registered depth frames (read once).
const std::vector<lightskin::RgbdFrame>& oniFrames() {
    static const std::vector<lightskin::RgbdFrame> frames = [] {
        std::vector<lightskin::RgbdFrame> out;
        auto source =
            lightskin::capture::openFrameSource(LIGHTSKIN_SOURCE_DIR "/tests/data/oni-kinect-v1/3dj_test.oni");
        lightskin::RgbdFrame frame;
        while (out.size() < 12 && source->next(frame)) out.push_back(frame.clone());
        return out;
    }();
    return frames;
}

void BM_BilateralOni(benchmark::State& state) {
    lightskin::capture::BilateralDepthFilterParams params;
    params.implementation = state.range(0) == 0 ? lightskin::capture::BilateralImplementation::Simd
                                                : lightskin::capture::BilateralImplementation::OpenCv;
    lightskin::capture::BilateralDepthFilter filter(params);
    const auto& frames = oniFrames();
    if (frames.empty()) {
        state.SkipWithError("tests/data/oni-kinect-v1/3dj_test.oni gave no frame");
        return;
    }
    cv::Mat out;
    std::size_t i = 0;
    filter.filterInto(frames[0].depth, frames[0].depthScaleMetres, out);
    for (auto _ : state) {
        const lightskin::RgbdFrame& f = frames[i++ % frames.size()];
        filter.filterInto(f.depth, f.depthScaleMetres, out);
        benchmark::DoNotOptimize(out.data);
    }
    state.SetLabel(std::string(state.range(0) == 0 ? "Simd" : "OpenCv") + ", .oni " +
                   std::to_string(frames[0].depth.cols) + "x" + std::to_string(frames[0].depth.rows) + ", " +
                   std::to_string(cv::getNumThreads()) + " OpenCV threads");
}
// alternated Simd, OpenCv, Simd, OpenCv: side by side in one run
BENCHMARK(BM_BilateralOni)->Arg(0)->Arg(1)->Arg(0)->Arg(1)->MeasureProcessCPUTime()->Unit(benchmark::kMillisecond);

} // namespace

BENCHMARK_MAIN();
