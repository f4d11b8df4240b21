#pragma once
// Backends behind openFrameSource(); one file each.
#include <lightskin/capture/FrameSource.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

namespace lightskin::capture::detail {

std::unique_ptr<FrameSource> openRecordingSource(const std::filesystem::path& folder,
                                                 const FrameSourceOptions& options);
std::unique_ptr<FrameSource> openTumSource(const std::filesystem::path& folder, const FrameSourceOptions& options);
/// `uri` empty = first device; otherwise an OpenNI2 device URI or a .oni path.
std::unique_ptr<FrameSource> openOpenNI2Source(const std::string& uri, bool file, const FrameSourceOptions& options);
std::unique_ptr<FrameSource> openFreenectSource(int deviceIndex, const FrameSourceOptions& options);

} // namespace lightskin::capture::detail

namespace lightskin::capture::detail {
/// Kinect v1 raw 11-bit disparity <-> millimetres (FreenectSource.cpp); 2047 / 0 = no measurement.
std::uint16_t millimetresFromDisparity(int disparity);
int disparityFromMillimetres(std::uint16_t millimetres);
} // namespace lightskin::capture::detail
