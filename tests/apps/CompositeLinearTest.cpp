// render::Compositor::compositeLinearInto, the linear composite behind replay's NaN/inf counts and
// --linear-out: covered pixels keep the renderer's unclamped linear value (HDR, NaN, inf), camera
// pixels are the sRGB-decoded camera image, the soft band is the 8-bit blend recomputed in float;
// sRGB-encoding it gives compositeInto()'s 8-bit output within 1 code value.
#include <lightskin/eval/ColourSpace.h>
#include <lightskin/eval/ImageMetrics.h>
#include <lightskin/render/Compositor.h>

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

using namespace lightskin;

namespace {

constexpr int kWidth = 6;

struct Layers {
    cv::Mat camera, virtualLinear, virtualRgba, virtualDepth;
};

/// Pixel 0: no virtual content. 1: HDR (2.0 in green). 2: NaN in red. 3: +inf in green.
/// 4 and 5: ordinary values in [0, 1]. Virtual surfaces at 1 m.
Layers makeLayers() {
    Layers l;
    l.camera.create(1, kWidth, CV_8UC3);
    for (int u = 0; u < kWidth; ++u) l.camera.at<cv::Vec3b>(0, u) = cv::Vec3b(std::uint8_t(20 + 40 * u), 128, std::uint8_t(230 - 30 * u));
    l.virtualLinear = cv::Mat(1, kWidth, CV_32FC4, cv::Scalar::all(0));
    l.virtualRgba = cv::Mat(1, kWidth, CV_8UC4, cv::Scalar::all(0));
    l.virtualDepth = cv::Mat(1, kWidth, CV_32FC1, cv::Scalar::all(0));
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    const cv::Vec4f values[kWidth] = {{0, 0, 0, 0}, {0.25f, 2.0f, 0.5f, 1}, {nan, 0.3f, 0.2f, 1}, {0.1f, inf, 0.4f, 1},
                                      {0.6f, 0.05f, 0.9f, 1}, {0.002f, 0.7f, 0.33f, 1}};
    for (int u = 1; u < kWidth; ++u) {
        l.virtualLinear.at<cv::Vec4f>(0, u) = values[u];
        cv::Vec4b& rgba = l.virtualRgba.at<cv::Vec4b>(0, u);
        for (int c = 0; c < 3; ++c) rgba[c] = cv::saturate_cast<std::uint8_t>(255.0f * eval::linearToSrgb(std::clamp(values[u][c], 0.0f, 1.0f)));
        rgba[3] = 255;
        l.virtualDepth.at<float>(0, u) = 1.0f;
    }
    return l;
}

render::Compositor makeCompositor() {
    CameraIntrinsics k;
    k.width = kWidth;
    k.height = 1;
    k.fx = k.fy = 10.0;
    k.cx = 2.5;
    k.cy = 0.0;
    return render::Compositor::create(k);
}

TEST(CompositeLinear, CoveredPixelsKeepHdrNanAndInfCameraPixelsAreDecoded) {
    const Layers l = makeLayers();
    render::Compositor compositor = makeCompositor();
    cv::Mat linear;
    compositor.compositeLinearInto(l.camera, l.virtualLinear, l.virtualRgba, l.virtualDepth, cv::Mat(), linear);
    ASSERT_EQ(linear.type(), CV_32FC3);
    for (int c = 0; c < 3; ++c)
        EXPECT_FLOAT_EQ(linear.at<cv::Vec3f>(0, 0)[c], eval::srgbToLinear(float(l.camera.at<cv::Vec3b>(0, 0)[c]) / 255.0f));
    EXPECT_FLOAT_EQ(linear.at<cv::Vec3f>(0, 1)[1], 2.0f);  // HDR kept (the PNG shows 255)
    EXPECT_FLOAT_EQ(linear.at<cv::Vec3f>(0, 1)[0], 0.5f);  // RGBA -> BGR
    EXPECT_TRUE(std::isnan(linear.at<cv::Vec3f>(0, 2)[2])); // red NaN -> BGR index 2
    EXPECT_TRUE(std::isinf(linear.at<cv::Vec3f>(0, 3)[1]));
    EXPECT_EQ(eval::countNonFinite(linear), 2u);
}

TEST(CompositeLinear, SoftBandBlendMatchesThe8BitCompositeAndPassesNanThrough) {
    const Layers l = makeLayers();
    render::Compositor compositor = makeCompositor();
    // Real surfaces at the virtual depth: visibility 0.5 everywhere (the middle of the soft band).
    const cv::Mat realDepth(1, kWidth, CV_32FC1, cv::Scalar(1.0));
    cv::Mat linear, composite8;
    compositor.compositeLinearInto(l.camera, l.virtualLinear, l.virtualRgba, l.virtualDepth, realDepth, linear);
    compositor.compositeInto(l.camera, l.virtualRgba, l.virtualDepth, realDepth, composite8);
    EXPECT_TRUE(std::isnan(linear.at<cv::Vec3f>(0, 2)[2]));
    EXPECT_TRUE(std::isinf(linear.at<cv::Vec3f>(0, 3)[1]));
    // Finite pixels: the 8-bit composite within 1 code value, and a real blend (not either input).
    cv::Mat encoded;
    eval::linearToSrgb8Into(linear, encoded);
    for (const int u : {0, 1, 4, 5}) {
        SCOPED_TRACE("pixel " + std::to_string(u));
        for (int c = 0; c < 3; ++c) EXPECT_LE(std::abs(int(encoded.at<cv::Vec3b>(0, u)[c]) - int(composite8.at<cv::Vec3b>(0, u)[c])), 1);
    }
    const float camera = eval::srgbToLinear(float(l.camera.at<cv::Vec3b>(0, 4)[0]) / 255.0f);
    const float expected = eval::srgbToLinear(0.5f * float(l.camera.at<cv::Vec3b>(0, 4)[0]) / 255.0f + 0.5f * eval::linearToSrgb(0.9f));
    EXPECT_NEAR(linear.at<cv::Vec3f>(0, 4)[0], expected, 1e-5f);
    EXPECT_GT(std::abs(linear.at<cv::Vec3f>(0, 4)[0] - camera), 0.05f);
    EXPECT_GT(std::abs(linear.at<cv::Vec3f>(0, 4)[0] - 0.9f), 0.05f);
}

} // namespace
