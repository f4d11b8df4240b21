#pragma once
// Helpers shared by the capture tests: deterministic synthetic frames.
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/capture/Recording.h>
#include <lightskin/core/RgbdFrame.h>

#include <opencv2/core.hpp>

#include <cstdint>
#include <filesystem>
#include <string>

namespace lightskin::test {

inline capture::RecordingInfo smallRecordingInfo(int width = 32, int height = 24) {
    capture::RecordingInfo info;
    info.deviceName = "synthetic test camera";
    info.colourIntrinsics = info.depthIntrinsics = CameraIntrinsics{
        width, height, 30.0, 31.0, width / 2.0 - 0.5, height / 2.0 - 0.5, {0.1, -0.2, 0.001, 0.002, 0.05}};
    info.depthScaleMetres = 0.001;
    return info;
}

/// A frame whose pixels are a deterministic function of `seed` (full 16-bit depth range, every
/// colour channel value), so a lossy or shifted round trip cannot pass by accident.
inline RgbdFrame syntheticFrame(const capture::RecordingInfo& info, std::uint32_t seed) {
    RgbdFrame frame;
    frame.depth.create(info.depthIntrinsics.height, info.depthIntrinsics.width, CV_16UC1);
    frame.colour.create(info.colourIntrinsics.height, info.colourIntrinsics.width, CV_8UC3);
    cv::RNG rng(seed);
    rng.fill(frame.depth, cv::RNG::UNIFORM, 0, 65536);
    rng.fill(frame.colour, cv::RNG::UNIFORM, 0, 256);
    frame.depth.at<std::uint16_t>(0, 0) = 0;
    frame.depth.at<std::uint16_t>(0, 1) = 65535;
    frame.depthScaleMetres = info.depthScaleMetres;
    frame.colourIntrinsics = info.colourIntrinsics;
    frame.depthIntrinsics = info.depthIntrinsics;
    frame.colourTimestampSeconds = 100.0 + seed / 30.0 + 0.001;
    frame.depthTimestampSeconds = 100.0 + seed / 30.0;
    return frame;
}

inline bool identical(const cv::Mat& a, const cv::Mat& b) {
    return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

/// Reads every frame of `path` (the bad-input tests expect it to throw).
inline void readAll(const std::filesystem::path& path) {
    auto source = capture::openFrameSource(path.string());
    RgbdFrame frame;
    while (source->next(frame)) {
    }
}

/// A finished 3-frame recording of 32x24 frames in a scratch folder named `name`.
inline std::filesystem::path makeRecording(const std::string& name) {
    const auto folder = scratchDir(name) / "rec";
    const auto info = smallRecordingInfo();
    auto writer = capture::RecordingWriter::create(folder, info);
    for (std::uint32_t i = 0; i < 3; ++i) writer.write(syntheticFrame(info, i));
    return folder;
}

} // namespace lightskin::test
