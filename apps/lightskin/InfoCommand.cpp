// `lightskin info <recording|source>`: what a recording (or any frame source) holds: format
// version, device, intrinsics, depth scale, registration, frame count, duration, ground truth,
// whether it was finished or cut off.
#include "Commands.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/capture/Recording.h>
#include <lightskin/core/Error.h>

#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

namespace lightskin::apps {

namespace {

/// "t = (x, y, z) m, rotation a deg about (x, y, z)": the extrinsic as a reader checks it.
void printExtrinsic(const char* label, const Pose& colour_T_depth) {
    const glm::dvec3& t = colour_T_depth.translation();
    const glm::dquat q = colour_T_depth.rotation();
    const double angle = 2.0 * std::acos(std::min(1.0, std::abs(q.w)));
    const glm::dvec3 axis = angle > 1e-12 ? glm::normalize(glm::dvec3(q.x, q.y, q.z)) : glm::dvec3(0.0, 0.0, 1.0);
    std::printf("%s t = (%.4f, %.4f, %.4f) m, rotation %.3f deg about (%.3f, %.3f, %.3f)\n", label, t.x, t.y, t.z,
                angle * 180.0 / 3.14159265358979323846, axis.x, axis.y, axis.z);
}

void addInfoCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand("info", "Print what a recording (or .oni / TUM folder) holds");
    auto path = std::make_shared<std::string>();
    command->add_option("source", *path, "Recording folder, TUM folder, .oni file or device URI")->required();
    command->callback([path, &exitCode] {
        const std::filesystem::path folder(*path);
        if (std::filesystem::exists(folder / capture::kRecordingHeaderFile)) {
            const auto s = capture::readRecordingSummary(folder);
            std::printf("lightskin recording, format version %d\n", s.version);
            std::printf("device:        %s\n", s.info.deviceName.c_str());
            std::printf("colour:        %s (%s)\n", s.info.colourIntrinsics.describe().c_str(),
                        s.info.jpegColour ? "JPEG" : "PNG");
            std::printf("depth:         %s (16-bit PNG, %.6g m per unit)\n", s.info.depthIntrinsics.describe().c_str(),
                        s.info.depthScaleMetres);
            std::printf("registration:  %s\n", toString(s.info.registration));
            printExtrinsic("colour_T_depth:", s.info.colour_T_depth);
            if (s.info.registration == DepthRegistration::Unregistered)
                std::printf("               (replay and live register the depth in software with it)\n");
            std::printf("frames:        %lld (%lld with colour, %lld with depth, %lld with ground-truth pose)\n",
                        static_cast<long long>(s.frameCount), static_cast<long long>(s.framesWithColour),
                        static_cast<long long>(s.framesWithDepth), static_cast<long long>(s.framesWithGroundTruth));
            if (std::isfinite(s.firstTimestampSeconds))
                std::printf("time:          %.3f .. %.3f s (%.3f s)\n", s.firstTimestampSeconds, s.lastTimestampSeconds,
                            s.lastTimestampSeconds - s.firstTimestampSeconds);
            std::printf("size:          %.1f MB\n", double(s.totalBytes) / 1e6);
            std::printf("state:         %s\n",
                        s.finished ? "finished" : "cut off (no end marker): complete frames are readable");
        } else {
            auto source = capture::openFrameSource(*path);
            const auto& info = source->info();
            std::printf("%s source %s\n", info.kind.c_str(), info.uri.c_str());
            std::printf("device:        %s\n", info.deviceName.c_str());
            std::printf("colour:        %s\n", info.colourIntrinsics.describe().c_str());
            std::printf("depth:         %s (%.6g m per unit)\n", info.depthIntrinsics.describe().c_str(),
                        info.depthScaleMetres);
            if (info.softwareRegistration) {
                const capture::RegistrationCalibration& c = *info.softwareRegistration;
                std::printf("registration:  %s in software (the source's depth is unregistered)\n",
                            toString(info.registration));
                std::printf("depth camera:  %s\n", c.depth.describe().c_str());
                printExtrinsic("colour_T_depth:", c.colour_T_depth);
            } else {
                std::printf("registration:  %s\n", toString(info.registration));
                printExtrinsic("colour_T_depth:", info.colour_T_depth);
            }
            if (!info.calibrationSource.empty()) std::printf("calibration:   %s\n", info.calibrationSource.c_str());
            if (const auto count = source->frameCount())
                std::printf("frames:        %lld\n", static_cast<long long>(*count));
            else
                std::printf("frames:        live\n");
            std::printf("ground truth:  %s\n", info.hasGroundTruth ? "yes" : "no");
        }
        exitCode = 0;
    });
}

} // namespace

static const CommandRegistration registration{"info", &addInfoCommand};

} // namespace lightskin::apps
