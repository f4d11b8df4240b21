// `lightskin doctor`: checks that this machine can run lightskin (headless OpenGL 4.5 core,
// compute shaders, framebuffer readback), says which GI backend a scene's gi.backend "auto" gets on
// this renderer and why, and writes a self-test image.
#include "CliSupport.h"
#include "Commands.h"
#include "ImageOutput.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/common/Technique.h>
#include <lightskin/gl/Context.h>
#include <lightskin/gl/DebugOutput.h>
#include <lightskin/gl/SelfTest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <filesystem>
#include <numeric>
#include <unistd.h>
#include <vector>

namespace lightskin::apps {

namespace {
void addDoctorCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand(
        "doctor", "Check headless OpenGL 4.5 and which GI backend gi.backend auto picks; write a self-test image");
    auto output = std::make_shared<std::string>();
    command->add_option("--out", *output, "Write the self-test triangle as a PNG to this path");
    command->callback([output, &exitCode] {
        // --out is checked before the checks run: a path that cannot be written fails at once.
        if (!output->empty()) checkImageOutput(*output, {}, "--out");
        auto context = gl::createHeadlessContext();
        std::printf("renderer: %s\n", context->describe().c_str());
        // What the pipeline decides for LightSkin with the scene's default (FramePipeline::create, same rule).
        const gi::BackendChoice choice = gi::chooseBackend(gi::Technique::LightSkin, gi::BackendSetting::Auto,
                                                           std::nullopt, gi::classifyGlRenderer(context->renderer()));
        std::printf("GI backend (gi.backend \"auto\", the default): %s; %s\n",
                    std::string(gi::toString(choice.backend)).c_str(),
                    std::string(gi::toString(choice.reason)).c_str());

        const cv::Mat image = gl::renderSelfTestTriangle(256, 256);
        std::vector<std::uint32_t> values(100000);
        std::iota(values.begin(), values.end(), 1u);
        const std::uint32_t sum = gl::sumOnGpu(values);
        const std::uint32_t expected = std::accumulate(values.begin(), values.end(), 0u);
        gl::DebugOutput::throwIfErrors("doctor");

        const bool sumOk = sum == expected;
        const bool triangleOk = image.at<cv::Vec4b>(128, 128)[0] == 255 && image.at<cv::Vec4b>(5, 5)[0] == 0;
        std::printf("compute shader sum: %s\nrasterised triangle: %s\n", sumOk ? "ok" : "WRONG",
                    triangleOk ? "ok" : "WRONG");
        if (!output->empty()) {
            const std::filesystem::path path(*output);
            if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
            cv::Mat bgra;
            cv::cvtColor(image, bgra, cv::COLOR_RGBA2BGRA);
            if (!cv::imwrite(path.string(), bgra))
                throw Error(path.string(), std::nullopt, "could not write the image");
            std::printf("wrote %s\n", path.string().c_str());
        }
        exitCode = sumOk && triangleOk ? 0 : 1;
    });
}

} // namespace

static const CommandRegistration registration{"doctor", &addDoctorCommand};

} // namespace lightskin::apps
