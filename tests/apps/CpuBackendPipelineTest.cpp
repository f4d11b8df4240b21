// gi.backend "cpu" in the per-frame pipeline: the bundled synthetic recordings with
// their scenes (synth-orbit: bunny and cube, ~3.7k depth VALs, glossy + occlusion; synth-pan;
// synth-clean-channels) and the real Kinect v1 `.oni` (640x480, depth registered in software, the
// real-depth guards at work) through mr::FramePipeline with the GL and the CPU LightSkin backend;
// the indirect light of the two must agree per pixel, frame by frame.
//
// Tolerance: each backend is within 3e-3 relative + 1e-3 of the image's maximum of the double
// reference per pixel (tests/gi/gather/: the GL path in LightSkinGLTest, the CPU backend in
// CpuLightSkinGLTest, derived there; the block-wise float sums of n VALs add at most
// (15 + n / 16) roundings, ~7e-5 relative even for a 640x480 map of 18k VALs, inside that budget), so they differ by at
// most 6e-3 relative + 2e-3 of the maximum.
#include "GlTestEnvironment.h"
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/mr/FramePipeline.h>
#include <lightskin/render/Scene.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <ostream>
#include <string>
#include <vector>

using namespace lightskin;

namespace {

struct Recording {
    const char* name;      ///< test name
    const char* path;      ///< recording folder or file, relative to the source tree
    const char* sceneFile; ///< under recordings/scenes/
    mr::PoseMode pose = mr::PoseMode::GroundTruth;
};
// gtest would print the case as raw bytes (pointers), which ctest puts into the test's name.
void PrintTo(const Recording& recording, std::ostream* out) { *out << recording.name; }

std::vector<cv::Mat> indirectFrames(const Recording& recording, gi::Backend backend, int frames) {
    render::Scene scene = render::loadScene(test::sourceDir() / "recordings" / "scenes" / recording.sceneFile);
    scene.gi.backend = gi::settingOf(backend);
    auto source = capture::openFrameSource((test::sourceDir() / recording.path).string(), {});
    mr::PipelineOptions options;
    options.poseMode = recording.pose;
    options.compare = false;
    options.linearIndirect = true;
    auto pipeline = mr::FramePipeline::create(scene, source->info(), options);
    EXPECT_EQ(pipeline->techniqueName(), backend == gi::Backend::Cpu ? "lightskin-cpu" : "lightskin");
    EXPECT_EQ(pipeline->technique(), gi::Technique::LightSkin);
    EXPECT_EQ(pipeline->backend(), backend);
    std::vector<cv::Mat> out;
    RgbdFrame frame;
    mr::FrameOutput output;
    for (int i = 0; i < frames && source->next(frame); ++i) {
        pipeline->process(frame, output);
        EXPECT_GT(output.valCount, 500u) << "the scene must be lit by the depth VALs";
        out.push_back(output.linearIndirect.clone());
    }
    return out;
}

class CpuBackendPipeline : public test::GlTest, public ::testing::WithParamInterface<Recording> {};

TEST_P(CpuBackendPipeline, IndirectLightMatchesTheGlBackend) {
    constexpr int kFrames = 2;
    const std::vector<cv::Mat> gl = indirectFrames(GetParam(), gi::Backend::Gl, kFrames);
    const std::vector<cv::Mat> cpu = indirectFrames(GetParam(), gi::Backend::Cpu, kFrames);
    ASSERT_EQ(gl.size(), std::size_t(kFrames));
    ASSERT_EQ(cpu.size(), gl.size());
    for (std::size_t f = 0; f < gl.size(); ++f) {
        ASSERT_EQ(gl[f].type(), CV_32FC3);
        ASSERT_EQ(cpu[f].size(), gl[f].size());
        double largest = 0.0;
        cv::minMaxLoc(gl[f].reshape(1), nullptr, &largest);
        ASSERT_GT(largest, 0.0) << "frame " << f << ": the GL backend gave no indirect light";
        std::size_t lit = 0, bad = 0;
        double worst = 0.0;
        for (int v = 0; v < gl[f].rows; ++v)
            for (int u = 0; u < gl[f].cols; ++u) {
                const cv::Vec3f a = gl[f].at<cv::Vec3f>(v, u), b = cpu[f].at<cv::Vec3f>(v, u);
                if (a[0] > 0.0f || a[1] > 0.0f || a[2] > 0.0f) ++lit;
                for (int c = 0; c < 3; ++c) {
                    const double tolerance = 6e-3 * std::abs(double(a[c])) + 2e-3 * largest;
                    const double error = std::abs(double(b[c]) - double(a[c]));
                    worst = std::max(worst, error / tolerance);
                    if (error > tolerance) ++bad;
                }
            }
        EXPECT_GT(lit, std::size_t(200)) << "frame " << f << ": too few lit pixels to compare";
        EXPECT_EQ(bad, 0u) << "frame " << f << ": worst error / tolerance " << worst;
    }
}

INSTANTIATE_TEST_SUITE_P(BundledRecordings, CpuBackendPipeline,
                         ::testing::Values(Recording{"synth_orbit", "recordings/synth-orbit", "orbit.json"},
                                           Recording{"synth_pan", "recordings/synth-pan", "pan.json"},
                                           Recording{"synth_clean_channels", "recordings/synth-clean-channels",
                                                     "clean_channels.json"},
                                           Recording{"oni_kinect_v1", "tests/data/oni-kinect-v1/3dj_test.oni",
                                                     "oni_room.json", mr::PoseMode::Fixed}),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

} // namespace
