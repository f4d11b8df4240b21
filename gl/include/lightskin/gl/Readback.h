#pragma once
// Copies GPU images back to the CPU (tests, outputs, debug views). Not for per-frame hot paths
// unless the destination is reused: the *Into variants do not allocate when `out` already has
// the right size and type.

#include <lightskin/gl/Objects.h>

#include <opencv2/core/mat.hpp>

namespace lightskin::gl {

/// Reads a GL_RGBA32F (or any float colour) texture's level 0 as CV_32FC4, row 0 = bottom of
/// the GL image flipped to row 0 = top (image convention).
void readTextureRgba32fInto(const Texture& texture, cv::Mat& out);
/// The same for a texture this code does not own (e.g. gi::GBufferView's ids), width x height texels.
void readTextureRgba32fInto(GLuint texture, int width, int height, cv::Mat& out);
/// Reads a GL_RGBA8 texture as CV_8UC4 (RGBA order), flipped to top-down rows.
void readTextureRgba8Into(const Texture& texture, cv::Mat& out);
/// Reads a single-channel float texture (GL_R32F) as CV_32FC1, flipped to top-down rows.
void readTextureR32fInto(const Texture& texture, cv::Mat& out);

} // namespace lightskin::gl
