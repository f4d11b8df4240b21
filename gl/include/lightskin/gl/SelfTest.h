#pragma once
// Small end-to-end checks of a context: used by `lightskin doctor` and the GL tests.

#include <opencv2/core/mat.hpp>

#include <cstdint>
#include <span>

namespace lightskin::gl {

/// Renders the triangle (-0.5,-0.5), (0.5,-0.5), (0,0.5) in NDC with colour (red,0,0) on black
/// into a width x height GL_RGBA8 framebuffer; returns CV_8UC4 RGBA, top row first.
cv::Mat renderSelfTestTriangle(int width, int height, float red = 1.0f);

/// Sums `values` with a compute shader (64-wide groups, shared-memory atomics). Wraps modulo 2^32.
std::uint32_t sumOnGpu(std::span<const std::uint32_t> values);

} // namespace lightskin::gl
