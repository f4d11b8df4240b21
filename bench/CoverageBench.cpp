// lightskin_bench_coverage: LightSkin's error against the brute force on the same VALs as a function of the sparse
// points and of the pixels the objects cover: whether points beyond the covered pixels still buy accuracy (the
// frame budget's error model has no coverage term; docs/PLUGIN.md "The frame budget"). A separate program, never a
// test:
//   build/bench/lightskin_bench_coverage <recording> <scene> [sparse points per object ...]
// The scene's objects are lit as the scene says but without occlusion (the brute force has none), at every sparse
// point count given (default 256 1024 4096), through the production pipeline (ground-truth poses, the default
// backend). Printed per count: the median over frames of the covered pixels, of the relative MSE of LightSkin's
// indirect light against the brute force's on them (sum (L - B)^2 / sum B^2, linear RGB) and of the GI stage's time.
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/gl/Context.h>
#include <lightskin/mr/FramePipeline.h>
#include <lightskin/render/Scene.h>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

using namespace lightskin;

double median(std::vector<double> values) {
    if (values.empty()) return -1.0;
    std::sort(values.begin(), values.end());
    return values[values.size() / 2];
}

/// sum (a - b)^2 / sum b^2 over the covered pixels (CV_32FC3 images, CV_8UC1 coverage).
double relativeMse(const cv::Mat& a, const cv::Mat& b, const cv::Mat& coverage) {
    double error = 0.0, signal = 0.0;
    for (int v = 0; v < a.rows; ++v)
        for (int u = 0; u < a.cols; ++u) {
            if (!coverage.at<std::uint8_t>(v, u)) continue;
            const cv::Vec3f x = a.at<cv::Vec3f>(v, u), y = b.at<cv::Vec3f>(v, u);
            for (int c = 0; c < 3; ++c) {
                error += double(x[c] - y[c]) * double(x[c] - y[c]);
                signal += double(y[c]) * double(y[c]);
            }
        }
    return signal > 0.0 ? error / signal : -1.0;
}

double stageMs(const mr::FrameOutput& out, const std::string& name) {
    for (const gl::StageTime& t : out.cpuTimes)
        if (t.name == name) return t.milliseconds;
    return -1.0;
}

} // namespace

int main(int argc, char** argv) try {
    if (argc < 3) {
        std::fprintf(stderr, "usage: lightskin_bench_coverage <recording> <scene> [sparse points per object ...]\n");
        return 64;
    }
    const std::string recording = argv[1], scenePath = argv[2];
    std::vector<int> counts;
    for (int i = 3; i < argc; ++i) counts.push_back(std::atoi(argv[i]));
    if (counts.empty()) counts = {256, 1024, 4096};
    auto context = gl::createHeadlessContext();
    std::printf("| scene | sparse points per object | objects | covered pixels (median) | relative MSE vs the brute "
                "force (median) | GI stage ms (median) |\n|---|---|---|---|---|---|\n");
    for (const int count : counts) {
        render::Scene scene = render::loadScene(scenePath);
        scene.gi.sparsePoints = count;
        scene.gi.occlusion = false;
        auto source = capture::openFrameSource(recording);
        mr::PipelineOptions options;
        options.poseMode = mr::PoseMode::GroundTruth;
        options.compare = false;
        options.view = render::DebugView::IndirectOnly;
        options.referenceIndirect = true;
        auto pipeline = mr::FramePipeline::create(scene, source->info(), options);
        std::vector<double> pixels, errors, giMs;
        RgbdFrame frame;
        mr::FrameOutput out;
        while (source->next(frame)) {
            pipeline->process(frame, out);
            if (out.linearIndirect.empty() || out.linearIndirectReference.empty()) continue;
            pixels.push_back(double(cv::countNonZero(out.coverage)));
            errors.push_back(relativeMse(out.linearIndirect, out.linearIndirectReference, out.coverage));
            giMs.push_back(stageMs(out, "gbuffer+gi"));
        }
        std::printf("| %s | %d | %zu | %.0f | %.5f | %.1f |\n", scenePath.c_str(), count,
                    pipeline->renderer().instances().size(), median(pixels), median(errors), median(giMs));
        std::fflush(stdout);
    }
    return 0;
} catch (const std::exception& error) {
    std::fprintf(stderr, "lightskin_bench_coverage: %s\n", error.what());
    return 1;
}
