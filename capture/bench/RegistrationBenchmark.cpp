// Cost of software depth-to-colour registration per 640x480 Kinect v1 frame (Google Benchmark):
// capture::DepthRegistrar::registerInto against OpenCV contrib's cv::rgbd::registerDepth on the same
// frame and calibration, and how far their outputs agree (printed once).
//   build/capture/lightskin_bench_registration [--benchmark_repetitions=5]
// Input: frame 3 of tests/data/oni-kinect-v1/3dj_test.oni (raw, unregistered), its stream
// intrinsics and the Kinect v1 default extrinsic (capture/Registration.h).
#include <lightskin/capture/FrameSource.h>
#include <lightskin/capture/Registration.h>

#include <benchmark/benchmark.h>
#include <glm/gtc/quaternion.hpp>
#include <opencv2/core.hpp>
#include <opencv2/rgbd/depth.hpp>

#include <cstdio>
#include <cstdlib>

namespace {

struct Input {
    cv::Mat depth;
    lightskin::capture::RegistrationCalibration calibration;
};

const Input& input() {
    static const Input in = [] {
        lightskin::capture::FrameSourceOptions options;
        options.softwareRegistration = false;
        auto source =
            lightskin::capture::openFrameSource(LIGHTSKIN_SOURCE_DIR "/tests/data/oni-kinect-v1/3dj_test.oni", options);
        lightskin::RgbdFrame frame;
        for (int i = 0; i < 4; ++i)
            if (!source->next(frame)) std::abort();
        Input result;
        result.depth = frame.depth.clone();
        result.calibration = {source->info().depthIntrinsics, source->info().colourIntrinsics,
                              source->info().colour_T_depth, "bench"};
        return result;
    }();
    return in;
}

cv::Matx33f cameraMatrix(const lightskin::CameraIntrinsics& k) {
    return {float(k.fx), 0.0f, float(k.cx), 0.0f, float(k.fy), float(k.cy), 0.0f, 0.0f, 1.0f};
}

void runOpenCv(const Input& in, cv::Mat& out) {
    const glm::dmat3 r = glm::mat3_cast(in.calibration.colour_T_depth.rotation());
    const glm::dvec3 t = in.calibration.colour_T_depth.translation();
    cv::Matx44f rt = cv::Matx44f::eye();
    for (int row = 0; row < 3; ++row) {
        for (int column = 0; column < 3; ++column) rt(row, column) = float(r[column][row]);
        rt(row, 3) = float(t[row]);
    }
    const auto& kc = in.calibration.colour;
    cv::rgbd::registerDepth(cameraMatrix(in.calibration.depth), cameraMatrix(kc), cv::Mat(), rt, in.depth,
                            cv::Size(kc.width, kc.height), out, false);
}

void BM_DepthRegistrar(benchmark::State& state) {
    const Input& in = input();
    const auto registrar = lightskin::capture::DepthRegistrar::create(in.calibration);
    cv::Mat out;
    registrar.registerInto(in.depth, 0.001, out);
    const void* buffer = out.data;
    for (auto _ : state) {
        registrar.registerInto(in.depth, 0.001, out);
        benchmark::DoNotOptimize(out.data);
    }
    state.SetLabel(std::string("output buffer ") + (out.data == buffer ? "reused" : "reallocated"));
}
BENCHMARK(BM_DepthRegistrar)->Unit(benchmark::kMillisecond);

void BM_OpenCvRegisterDepth(benchmark::State& state) {
    const Input& in = input();
    cv::Mat out;
    runOpenCv(in, out);
    const void* buffer = out.data;
    bool reallocated = false;
    for (auto _ : state) {
        runOpenCv(in, out);
        reallocated = reallocated || out.data != buffer;
        buffer = out.data;
        benchmark::DoNotOptimize(out.data);
    }
    // Agreement with DepthRegistrar (printed in the label): valid pixels in each, and the share of
    // pixels valid in both whose values differ by at most 1 unit (1 mm).
    const auto registrar = lightskin::capture::DepthRegistrar::create(in.calibration);
    cv::Mat ours;
    registrar.registerInto(in.depth, 0.001, ours);
    int both = 0, agree = 0;
    for (int v = 0; v < ours.rows; ++v)
        for (int u = 0; u < ours.cols; ++u) {
            const int a = ours.at<std::uint16_t>(v, u), b = out.at<std::uint16_t>(v, u);
            if (a == 0 || b == 0) continue;
            ++both;
            agree += std::abs(a - b) <= 1 ? 1 : 0;
        }
    char label[160];
    std::snprintf(label, sizeof label, "output buffer %s; valid %d (ours %d), %.4f of both within 1 mm",
                  reallocated ? "reallocated" : "reused", cv::countNonZero(out), cv::countNonZero(ours),
                  both > 0 ? double(agree) / both : 0.0);
    state.SetLabel(label);
}
BENCHMARK(BM_OpenCvRegisterDepth)->Unit(benchmark::kMillisecond);

} // namespace

BENCHMARK_MAIN();
