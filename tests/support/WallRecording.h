#pragma once
// The small recording the end-to-end tests of the `lightskin` program run on (tests/apps): a wall at
// 1.5 m with a box at 0.8 m in the left third, the camera 1 m in front of the world origin looking at
// it and translating 1 cm per frame along x, ground truth in every frame. Library: lightskin_test_recording.
#include <opencv2/core/types.hpp>

#include <filesystem>
#include <functional>
#include <string>

namespace lightskin::test {

/// Size of the recording: 64 x 48 pixels, 6 frames at 30 fps.
inline constexpr int kWallWidth = 64, kWallHeight = 48, kWallFrames = 6;

/// The colour of pixel (u, v) (column, row), 8-bit BGR as written to the colour PNGs.
using WallColour = std::function<cv::Vec3b(int u, int v)>;

/// Writes the recording into `folder` (must not exist or be empty), depth in millimetres
/// (depthScaleMetres 0.001), colour from `colour`, intrinsics fx = fy = 60 px, principal point at the
/// image centre. Returns `folder`. Throws lightskin::Error from the recording writer.
std::filesystem::path writeWallRecording(const std::filesystem::path& folder, const WallColour& colour,
                                         const std::string& deviceName = "wall test");

} // namespace lightskin::test
