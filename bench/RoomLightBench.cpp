// lightskin_bench_roomlight: time per frame of the room light estimator (roomlight/) and its hold-out accuracy on
// real recordings. A separate program, never a test; the numbers go to docs/ROOMLIGHT.md with this command:
//   build/bench/lightskin_bench_roomlight [repeats=40] [stride=4] [recording...]
// Without recordings: the five bundled ones in tests/data (TUM fr2 desk, TUM fr3 office, ICL-NUIM, the PCL TIFF
// frame, the Kinect v1 .oni). Per recording, on its first frame: the cold frame (first frame: the free light's
// global search) and the warm frames (the next frames: the search warm-started from the last light), each the
// median of `repeats` runs of estimate() alone (the frame is decoded once); then the hold-out comparison.
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/CpuTime.h>
#include <lightskin/core/Error.h>
#include <lightskin/roomlight/HoldOutEvaluation.h>
#include <lightskin/roomlight/RoomLightEstimator.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

namespace {

using namespace lightskin;

double medianOf(std::vector<double>& values) {
    std::sort(values.begin(), values.end());
    return values[values.size() / 2];
}

void benchRecording(const std::string& path, int repeats, const roomlight::RoomLightOptions& options) {
    auto source = capture::openFrameSource(path);
    RgbdFrame frame;
    if (!source->next(frame)) throw Error(path, std::nullopt, "the recording has no frame");
    std::vector<double> cold, warm;
    for (int run = 0; run < repeats; ++run) {
        roomlight::RoomLightEstimator estimator(options);
        frame.colourTimestampSeconds = 0.0;
        double start = threadCpuMs();
        estimator.estimate(frame, Pose());
        cold.push_back(threadCpuMs() - start);
        frame.colourTimestampSeconds = 1.0 / 30.0;
        start = threadCpuMs();
        const roomlight::LightEstimate& estimate = estimator.estimate(frame, Pose());
        warm.push_back(threadCpuMs() - start);
        if (estimate.state != roomlight::EstimateState::Fitted)
            std::printf("  (frame not fitted: %s)\n", roomlight::toString(estimate.problem));
    }
    const roomlight::HoldOutResult holdOut = roomlight::evaluateHoldOut(frame, Pose(), options);
    std::printf("| %s | %dx%d | %d | %.2f | %.2f | %.3f | %.3f | %s |\n", path.c_str(), frame.colourIntrinsics.width,
                frame.colourIntrinsics.height, holdOut.estimate.samplesFitted, medianOf(cold), medianOf(warm),
                holdOut.estimateRelativeRmse, holdOut.ambientOnlyRelativeRmse,
                roomlight::toString(holdOut.estimate.dominant.source));
}

} // namespace

int main(int argc, char** argv) {
    const int repeats = argc > 1 ? std::atoi(argv[1]) : 40;
    roomlight::RoomLightOptions options;
    options.stride = argc > 2 ? std::atoi(argv[2]) : 4;
    if (repeats < 1 || options.stride < 1) {
        std::fprintf(stderr, "usage: lightskin_bench_roomlight [repeats>=1] [stride>=1] [recording...]\n");
        return 2;
    }
    std::vector<std::string> recordings;
    for (int i = 3; i < argc; ++i) recordings.emplace_back(argv[i]);
    if (recordings.empty()) {
        const std::string data = LIGHTSKIN_TEST_DATA_DIR;
        recordings = {data + "/tum-fr2-desk", data + "/tum-fr3-office", data + "/icl-nuim-open3d",
                      data + "/pcl-kinect-tiff", data + "/oni-kinect-v1/3dj_test.oni"};
    }
    std::printf("stride %d, %d repeats; times are medians of estimate() alone, thread CPU time, one thread\n\n",
                options.stride, repeats);
    std::printf("| recording | size | samples fitted | first frame ms | next frames ms | hold-out rel. RMSE | "
                "ambient-only | dominant |\n|---|---|---|---|---|---|---|---|\n");
    try {
        for (const std::string& recording : recordings) benchRecording(recording, repeats, options);
    } catch (const Error& error) {
        std::fprintf(stderr, "lightskin_bench_roomlight: %s\n", error.what());
        return 1;
    }
    return 0;
}
