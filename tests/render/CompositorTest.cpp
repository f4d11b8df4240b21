#include <lightskin/render/Compositor.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <limits>

using namespace lightskin;

namespace {
cv::Mat noiseImage(int w, int h) {
    cv::Mat image(h, w, CV_8UC3);
    cv::randu(image, 0, 256);
    return image;
}
} // namespace

TEST(Compositor, NoVirtualContentGivesTheInputBitExact) {
    const CameraIntrinsics k{64, 48, 60.0, 60.0, 31.5, 23.5, {}};
    render::Compositor compositor = render::Compositor::create(k);
    const cv::Mat camera = noiseImage(64, 48);
    const cv::Mat virtualColour(48, 64, CV_8UC4, cv::Scalar::all(0));
    const cv::Mat virtualDepth(48, 64, CV_32FC1, cv::Scalar(0));
    cv::Mat realDepth(48, 64, CV_32FC1);
    cv::randu(realDepth, 0.0, 4.0);
    cv::Mat out;
    compositor.compositeInto(camera, virtualColour, virtualDepth, realDepth, out);
    EXPECT_EQ(cv::norm(out, camera, cv::NORM_INF), 0.0);
    compositor.compositeInto(camera, virtualColour, virtualDepth, cv::Mat(), out);
    EXPECT_EQ(cv::norm(out, camera, cv::NORM_INF), 0.0);
}

TEST(Compositor, CoveredPixelsInFrontOfRealDepthShowTheVirtualColour) {
    const CameraIntrinsics k{8, 4, 10.0, 10.0, 3.5, 1.5, {}};
    render::Compositor compositor = render::Compositor::create(k);
    const cv::Mat camera(4, 8, CV_8UC3, cv::Scalar(10, 20, 30));
    cv::Mat virtualColour(4, 8, CV_8UC4, cv::Scalar::all(0));
    cv::Mat virtualDepth(4, 8, CV_32FC1, cv::Scalar(0));
    virtualColour.at<cv::Vec4b>(1, 2) = {200, 100, 50, 255}; // RGBA
    virtualDepth.at<float>(1, 2) = 1.0f;
    virtualColour.at<cv::Vec4b>(1, 5) = {200, 100, 50, 255};
    virtualDepth.at<float>(1, 5) = 1.0f;
    cv::Mat realDepth(4, 8, CV_32FC1, cv::Scalar(2.0f));
    realDepth.at<float>(1, 5) = 0.5f; // a real surface in front of the second virtual pixel
    cv::Mat out;
    compositor.compositeInto(camera, virtualColour, virtualDepth, realDepth, out);
    EXPECT_EQ(out.at<cv::Vec3b>(1, 2), cv::Vec3b(50, 100, 200)); // BGR
    EXPECT_EQ(out.at<cv::Vec3b>(1, 5), cv::Vec3b(10, 20, 30));
    EXPECT_EQ(out.at<cv::Vec3b>(0, 0), cv::Vec3b(10, 20, 30));
}

TEST(Compositor, SoftBandIsLinearAndCentredOnEqualDepth) {
    const render::CompositeSettings s{3.0f, 0.005f};
    const float z = 2.0f;
    const float band = 3.0f * (0.0012f + 0.0019f * 1.6f * 1.6f); // 0.01819 m at 2 m
    EXPECT_FLOAT_EQ(render::visibility(z, z, s), 0.5f);
    EXPECT_FLOAT_EQ(render::visibility(z, z + band, s), 1.0f);
    EXPECT_FLOAT_EQ(render::visibility(z, z - band, s), 0.0f);
    EXPECT_NEAR(render::visibility(z, z + 0.5f * band, s), 0.75f, 1e-5f);
    EXPECT_FLOAT_EQ(render::visibility(z, 0.0f, s), 1.0f); // missing depth never hides
    // Near the camera the noise is smaller than the minimum: the band is 5 mm.
    EXPECT_NEAR(render::visibility(0.5f, 0.5f + 0.0025f, s), 0.75f, 1e-4f);
}

TEST(Compositor, DistortionWarpsTheVirtualLayer) {
    // A pixel of the ideal render lands where the distortion model sends it in the camera image.
    CameraIntrinsics k = CameraIntrinsics::tumFreiburg1();
    render::Compositor compositor = render::Compositor::create(k);
    const cv::Mat camera(k.height, k.width, CV_8UC3, cv::Scalar::all(0));
    cv::Mat virtualColour(k.height, k.width, CV_8UC4, cv::Scalar::all(0));
    cv::Mat virtualDepth(k.height, k.width, CV_32FC1, cv::Scalar(0));
    // Ideal pixel (100, 80) -> distorted position by OpenCV's projectPoints.
    const double xn = (100.0 - k.cx) / k.fx, yn = (80.0 - k.cy) / k.fy;
    const double r2 = xn * xn + yn * yn, k1 = k.distortion[0], k2 = k.distortion[1], p1 = k.distortion[2],
                 p2 = k.distortion[3], k3 = k.distortion[4];
    const double radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
    const double xd = xn * radial + 2 * p1 * xn * yn + p2 * (r2 + 2 * xn * xn);
    const double yd = yn * radial + p1 * (r2 + 2 * yn * yn) + 2 * p2 * xn * yn;
    const int ud = int(std::lround(k.fx * xd + k.cx)), vd = int(std::lround(k.fy * yd + k.cy));
    virtualColour(cv::Rect(99, 79, 3, 3)).setTo(cv::Scalar(255, 255, 255, 255));
    virtualDepth(cv::Rect(99, 79, 3, 3)).setTo(cv::Scalar(1.0));
    cv::Mat out;
    compositor.compositeInto(camera, virtualColour, virtualDepth, cv::Mat(), out);
    EXPECT_EQ(out.at<cv::Vec3b>(vd, ud), cv::Vec3b(255, 255, 255)) << "expected at " << ud << "," << vd;
    EXPECT_GT(std::abs(ud - 100) + std::abs(vd - 80), 2); // the distortion really moves it here
}

// visibleInto() against the composite itself (compositeLinearInto, a separate code path through the blend): on a
// black camera image with the virtual linear value 1 everywhere covered, an output pixel is > 0 exactly where the
// composite blends a share a > 0 of the virtual pixel (sRGB decode of encode(1) a > 0 for any a > 0). The real
// depth is drawn around the virtual depth over +-2 soft bands, so pixels fully shown, in the band and hidden all
// occur; missing real depth (0) and uncovered pixels too. Distortion: no band (real depth 10 cm in front or
// behind), each render pixel's value is its index + 1, so each output pixel names the render pixel it shows.
TEST(Compositor, VisibleMaskIsWhereTheCompositeShowsTheVirtualPixel) {
    const CameraIntrinsics k{64, 48, 60.0, 60.0, 31.5, 23.5, {}};
    render::Compositor compositor = render::Compositor::create(k);
    const cv::Mat camera(48, 64, CV_8UC3, cv::Scalar::all(0));
    cv::Mat virtualColour(48, 64, CV_8UC4, cv::Scalar(255, 255, 255, 255));
    const cv::Mat virtualLinear(48, 64, CV_32FC4, cv::Scalar::all(1.0));
    const cv::Mat virtualDepth(48, 64, CV_32FC1, cv::Scalar(1.5));
    const float band = 3.0f * render::kinectAxialNoiseMetres(1.5f); // softBandSigmas 3 > the 5 mm minimum at 1.5 m
    cv::Mat realDepth(48, 64, CV_32FC1);
    cv::RNG rng(12);
    for (int v = 0; v < 48; ++v)
        for (int u = 0; u < 64; ++u) realDepth.at<float>(v, u) = 1.5f + float(rng.uniform(-2.0, 2.0)) * band;
    realDepth(cv::Rect(0, 0, 8, 8)).setTo(cv::Scalar(0.0));          // missing depth never hides
    virtualColour(cv::Rect(56, 40, 8, 8)).setTo(cv::Scalar::all(0)); // uncovered
    cv::Mat visible, out;
    compositor.visibleInto(virtualColour, virtualDepth, realDepth, visible);
    compositor.compositeLinearInto(camera, virtualLinear, virtualColour, virtualDepth, realDepth, out);
    int shown = 0, hidden = 0, band01 = 0;
    for (int v = 0; v < 48; ++v)
        for (int u = 0; u < 64; ++u) {
            const bool composited = out.at<cv::Vec3f>(v, u)[1] > 0.0f;
            EXPECT_EQ(visible.at<std::uint8_t>(v, u) != 0, composited) << "pixel " << u << "," << v;
            shown += composited ? 1 : 0;
            hidden += composited ? 0 : 1;
            const float a = render::visibility(1.5f, realDepth.at<float>(v, u), compositor.settings());
            band01 += a > 0.0f && a < 1.0f ? 1 : 0;
        }
    EXPECT_GT(hidden, 64 * 48 / 5); // a quarter of the draws lie beyond the band behind, plus the uncovered block
    EXPECT_GT(shown, 64 * 48 / 2);
    EXPECT_GT(band01, 64 * 48 / 3); // half of the draws lie inside the band: partly shown, counted as shown

    CameraIntrinsics distorted = CameraIntrinsics::tumFreiburg1();
    render::Compositor warping = render::Compositor::create(distorted);
    const cv::Size size(distorted.width, distorted.height);
    const cv::Mat black(size, CV_8UC3, cv::Scalar::all(0));
    cv::Mat colour(size, CV_8UC4, cv::Scalar::all(255)), depth(size, CV_32FC1, cv::Scalar(1.0)), linear(size, CV_32FC4);
    cv::Mat real(size, CV_32FC1);
    for (int v = 0; v < size.height; ++v)
        for (int u = 0; u < size.width; ++u) {
            linear.at<cv::Vec4f>(v, u) = cv::Vec4f::all(float(v * size.width + u + 1));
            real.at<float>(v, u) = (u / 16 + v / 16) % 2 ? 1.1f : 0.9f; // checkerboard: behind / in front
        }
    warping.visibleInto(colour, depth, real, visible);
    warping.compositeLinearInto(black, linear, colour, depth, real, out);
    cv::Mat expected(size, CV_8UC1, cv::Scalar(0));
    for (int v = 0; v < size.height; ++v)
        for (int u = 0; u < size.width; ++u)
            if (const float value = out.at<cv::Vec3f>(v, u)[0]; value > 0.0f) {
                const int i = int(value) - 1;
                expected.at<std::uint8_t>(i / size.width, i % size.width) = 255;
            }
    EXPECT_GT(cv::countNonZero(expected), size.area() / 4);
    EXPECT_EQ(cv::norm(visible, expected, cv::NORM_INF), 0.0);
}

namespace {
float decode(std::uint8_t v) {
    const float c = float(v) / 255.0f;
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}
gi::DifferentialImages differentialImages(int w, int h) {
    gi::DifferentialImages d;
    d.deltaIrradiance = cv::Mat(h, w, CV_32FC3, cv::Scalar::all(0));
    d.irradianceWithout = cv::Mat(h, w, CV_32FC3, cv::Scalar::all(0));
    d.affected = cv::Mat(h, w, CV_8UC1, cv::Scalar(0));
    return d;
}
} // namespace

// Debevec's I + rho/pi dE with rho = pi L / E_without: the linear camera value scales by
// E_with / E_without; checked against that closed form in linear light. 8-bit output: within half a
// code value of the exact encoding, i.e. |decode(out) - expected| <= the decoded step at that value.
TEST(Compositor, DifferentialScalesTheCameraLightByEWithOverEWithout) {
    const cv::Mat camera = noiseImage(64, 48);
    gi::DifferentialImages d = differentialImages(64, 48);
    const float stops = 0.585f;
    for (int v = 0; v < 48; ++v)
        for (int u = 0; u < 32; ++u) { // left half affected: dE = -(u / 64) E_without, E_without = 2 + v / 10
            const float without = 2.0f + float(v) / 10.0f;
            d.irradianceWithout.at<cv::Vec3f>(v, u) = cv::Vec3f(without, without, without);
            d.deltaIrradiance.at<cv::Vec3f>(v, u) = cv::Vec3f::all(-float(u) / 64.0f * without);
            d.affected.at<std::uint8_t>(v, u) = 255;
        }
    cv::Mat out;
    render::applyDifferentialInto(camera, d, stops, out);
    const float gain = std::exp2(stops);
    int checked = 0;
    for (int v = 0; v < 48; ++v)
        for (int u = 0; u < 64; ++u)
            for (int c = 0; c < 3; ++c) {
                const std::uint8_t in = camera.at<cv::Vec3b>(v, u)[c], result = out.at<cv::Vec3b>(v, u)[c];
                if (u >= 32 || u == 0) {
                    ASSERT_EQ(result, in) << "unaffected or dE = 0: bit for bit";
                    continue;
                }
                const float p = decode(in), without = 2.0f + float(v) / 10.0f;
                // rho = pi p / (gain E) is clamped to 1 where the pixel is brighter than its modelled light.
                const float albedo = std::min(3.14159265f * p / gain / without, 1.0f);
                const float expected = std::max(p + gain * albedo / 3.14159265f * (-float(u) / 64.0f * without), 0.0f);
                const float step =
                    decode(std::uint8_t(std::min(255, result + 1))) - decode(std::uint8_t(std::max(0, result - 1)));
                ASSERT_NEAR(decode(result), expected, 0.5f * step + 1e-6f) << u << "," << v << "," << c;
                ++checked;
            }
    EXPECT_GT(checked, 4000);
}

// A pixel brighter than its modelled light allows (rho = pi p / (gain E_without) > 1) keeps albedo 1:
// rho / pi = 1 / pi exactly, not the pixel's ratio. Here p = decode(100) = 0.127, E_without = 0.1, gain 1:
// the ratio would give rho = 3.99, so clamped (0.159) and unclamped (0.254) results differ by 0.095 in
// linear light, ~25 code values there; the tolerance is half a code value as above.
TEST(Compositor, DifferentialClampsTheAlbedoOfPixelsBrighterThanTheirModelledLight) {
    const cv::Mat camera(4, 4, CV_8UC3, cv::Scalar::all(100));
    gi::DifferentialImages d = differentialImages(4, 4);
    d.affected.setTo(255);
    d.irradianceWithout.setTo(cv::Scalar::all(0.1));
    d.deltaIrradiance.setTo(cv::Scalar::all(0.1));
    cv::Mat out;
    render::applyDifferentialInto(camera, d, 0.0f, out);
    const float p = decode(100);
    ASSERT_GT(3.14159265f * p / 0.1f, 1.0f) << "the case must need the clamp";
    const float expected = p + 0.1f / 3.14159265f;
    for (int v = 0; v < 4; ++v)
        for (int u = 0; u < 4; ++u)
            for (int c = 0; c < 3; ++c) {
                const std::uint8_t result = out.at<cv::Vec3b>(v, u)[c];
                const float step =
                    decode(std::uint8_t(std::min(255, result + 1))) - decode(std::uint8_t(std::max(0, result - 1)));
                ASSERT_NEAR(decode(result), expected, 0.5f * step + 1e-6f) << u << "," << v << "," << c;
            }
}

TEST(Compositor, DifferentialLeavesPixelsWithoutModelledLightOrWithNonFiniteInput) {
    const cv::Mat camera = noiseImage(8, 4);
    gi::DifferentialImages d = differentialImages(8, 4);
    d.affected.setTo(255);
    d.deltaIrradiance.setTo(cv::Scalar::all(-1.0));
    d.irradianceWithout.at<cv::Vec3f>(0, 0) = cv::Vec3f(0, 0, 0);            // unknown albedo
    d.irradianceWithout.at<cv::Vec3f>(0, 1) = cv::Vec3f::all(std::nanf("")); // not finite
    d.deltaIrradiance.at<cv::Vec3f>(0, 2) = cv::Vec3f::all(std::numeric_limits<float>::infinity());
    d.irradianceWithout.at<cv::Vec3f>(0, 2) = cv::Vec3f(1, 1, 1);
    cv::Mat out;
    render::applyDifferentialInto(camera, d, 0.0f, out);
    for (int u = 0; u < 3; ++u) EXPECT_EQ(out.at<cv::Vec3b>(0, u), camera.at<cv::Vec3b>(0, u)) << u;
}
