#pragma once
// sRGB <-> linear conversions (IEC 61966-2-1 piecewise curve, not a 2.2 power).

#include <opencv2/core/mat.hpp>

namespace lightskin::eval {

float srgbToLinear(float encoded) noexcept;
float linearToSrgb(float linear) noexcept;

/// 8-bit sRGB (CV_8UC1/3/4) -> CV_32F with the same channels, linear in [0,1]. Alpha, if any,
/// is scaled but not linearised. Does not allocate when `out` already fits.
void srgb8ToLinearInto(const cv::Mat& srgb, cv::Mat& out);
/// Linear float (CV_32FC1/3/4) -> 8-bit sRGB, clamped to [0,1] first.
void linearToSrgb8Into(const cv::Mat& linear, cv::Mat& out);

} // namespace lightskin::eval
