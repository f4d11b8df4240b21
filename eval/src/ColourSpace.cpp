#include <lightskin/core/Error.h>
#include <lightskin/eval/ColourSpace.h>

#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>

namespace lightskin::eval {

float srgbToLinear(float encoded) noexcept {
    return encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

float linearToSrgb(float linear) noexcept {
    linear = std::clamp(linear, 0.0f, 1.0f);
    return linear <= 0.0031308f ? linear * 12.92f : 1.055f * std::pow(linear, 1.0f / 2.4f) - 0.055f;
}

void srgb8ToLinearInto(const cv::Mat& srgb, cv::Mat& out) {
    LIGHTSKIN_ASSERT(srgb.depth() == CV_8U, "srgb8ToLinearInto() needs an 8-bit image");
    static const std::array<float, 256> table = [] {
        std::array<float, 256> values{};
        for (std::size_t i = 0; i < values.size(); ++i) values[i] = srgbToLinear(float(i) / 255.0f);
        return values;
    }();
    const int channels = srgb.channels();
    out.create(srgb.size(), CV_MAKETYPE(CV_32F, channels));
    for (int row = 0; row < srgb.rows; ++row) {
        const std::uint8_t* in = srgb.ptr<std::uint8_t>(row);
        float* o = out.ptr<float>(row);
        for (int i = 0; i < srgb.cols * channels; ++i) {
            const bool alpha = channels == 4 && i % 4 == 3;
            o[i] = alpha ? float(in[i]) / 255.0f : table[in[i]];
        }
    }
}

void linearToSrgb8Into(const cv::Mat& linear, cv::Mat& out) {
    LIGHTSKIN_ASSERT(linear.depth() == CV_32F, "linearToSrgb8Into() needs a float image");
    const int channels = linear.channels();
    out.create(linear.size(), CV_MAKETYPE(CV_8U, channels));
    for (int row = 0; row < linear.rows; ++row) {
        const float* in = linear.ptr<float>(row);
        std::uint8_t* o = out.ptr<std::uint8_t>(row);
        for (int i = 0; i < linear.cols * channels; ++i) {
            const bool alpha = channels == 4 && i % 4 == 3;
            const float encoded = alpha ? std::clamp(in[i], 0.0f, 1.0f) : linearToSrgb(in[i]);
            o[i] = std::uint8_t(std::lround(encoded * 255.0f));
        }
    }
}

} // namespace lightskin::eval
