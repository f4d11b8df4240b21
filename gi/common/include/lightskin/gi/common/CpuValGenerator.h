#pragma once
// Virtual area lights from a depth map on the CPU: the per-pixel definition of
// ValGenerator.h, written as gi/common/shaders/val_from_depth.comp computes it (float, the same operations
// in the same order: sampling, validity, edge walk, gradient normal, area, flux, transform), so a
// frame's set equals the GL pass's up to float rounding of the few operations the GPU may evaluate
// differently (division, 1/sqrt in normalize, pow in the sRGB decode, which is a table here: the
// exact IEC 61966-2-1 value rounded to float). For the CPU GI backend: the depth frame is already
// on the CPU, so no upload, GL pass and read-back are needed.
//
// Differences from ValGenerator: the output is in raster order of the VAL map (deterministic,
// whatever the thread count), not in atomic-append order; no skipUnchangedInput (the settings field
// is ignored). Units and frames as ValGenerator: depth in metres (or raw 16-bit units times the
// scale), positions in the world frame (metres), flux in W, linear RGB.

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>
#include <lightskin/gi/common/ValGenerator.h>
#include <lightskin/gi/common/VirtualAreaLight.h>

#include <opencv2/core/mat.hpp>

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace lightskin::gi {

/// CPU VAL generation. Buffers are sized once for one depth-map size; generate() does not
/// allocate (except a 16-bit depth map's float copy, sized at create()).
class CpuValGenerator {
public:
    CpuValGenerator();
    ~CpuValGenerator();
    CpuValGenerator(CpuValGenerator&&) noexcept;
    CpuValGenerator& operator=(CpuValGenerator&&) noexcept;
    /// Sizes the buffers for depth maps of depthWidth x depthHeight; `threads` worker threads
    /// (0 = all hardware threads; speed only, the output does not depend on it). Throws
    /// lightskin::Error on bad settings, sizes or thread count.
    static CpuValGenerator create(int depthWidth, int depthHeight, const ValGeneratorSettings& settings = {},
                                  int threads = 0);

    /// The VALs of one frame (inputs as ValGenerator::generate: depth CV_16UC1 raw units times
    /// depthScaleMetres or CV_32FC1 metres, 0/NaN = missing; colour CV_8UC3 BGR sRGB, registered,
    /// same size). The span points into this generator and stays valid until the next call.
    /// Throws lightskin::Error on wrong types, sizes or intrinsics.
    std::span<const VirtualAreaLight> generate(const cv::Mat& depth, double depthScaleMetres, const cv::Mat& colourBgr,
                                               const CameraIntrinsics& depthIntrinsics, const Pose& world_T_camera);

    /// The last set, and per VAL the depth pixel (v * width + u) it samples.
    std::span<const VirtualAreaLight> lastVals() const noexcept { return {vals_.data(), count_}; }
    std::span<const std::uint32_t> lastPixelIndices() const noexcept { return {pixelIndices_.data(), count_}; }
    /// The depth-map size of create(), pixels: the image lastPixelIndices() index.
    int depthWidth() const noexcept { return width_; }
    int depthHeight() const noexcept { return height_; }
    /// The last set for in-place culls that zero a VAL's area (gi::ValOccupancyCull::applyOnCpu).
    std::span<VirtualAreaLight> mutableLastVals() noexcept { return {vals_.data(), count_}; }

    /// Exposure etc. may change per frame; stride and normalWindowRadius may not (buffer sizes).
    void setSettings(const ValGeneratorSettings& settings);
    const ValGeneratorSettings& settings() const noexcept { return settings_; }

private:
    ValGeneratorSettings settings_;
    int width_ = 0, height_ = 0;
    struct Workers; // the thread pool (oneTBB arena)
    std::unique_ptr<Workers> workers_;
    std::size_t count_ = 0;
    std::vector<VirtualAreaLight> slots_, vals_; // per VAL-map pixel; packed
    std::vector<std::uint8_t> valid_;            // per VAL-map pixel
    std::vector<std::uint32_t> pixelIndices_;
    std::array<float, 256> srgbToLinear_{};
    cv::Mat depthMetres_;
};

} // namespace lightskin::gi
