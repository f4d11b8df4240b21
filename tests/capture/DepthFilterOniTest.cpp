// The bilateral depth filter's two implementations (capture/DepthFilter.h) on real Kinect v1 depth:
// the .oni's registered frames, as the replay filters them. The SIMD one computes the range weights
// exactly (to 3e-7); the OpenCV one interpolates them in a table. They must differ by no more than
// that table's interpolation error allows, per pixel, and have the same holes.
#include "TestPaths.h"

#include <lightskin/capture/DepthFilter.h>
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/RgbdFrame.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

namespace lightskin::test {
namespace {

TEST(DepthFilterOniTest, SimdEqualsTheOpenCvFilterWithinItsRangeTableErrorOnKinectDepth) {
    const std::string path = std::filesystem::absolute(dataPath("oni-kinect-v1/3dj_test.oni")).string();
    auto source = capture::openFrameSource(path);
    capture::BilateralDepthFilterParams params; // the replay's (KinectFusion) parameters
    capture::BilateralDepthFilter simd(params);
    params.implementation = capture::BilateralImplementation::OpenCv;
    capture::BilateralDepthFilter opencv(params);
    const double sigma = params.sigmaDepthMetres;
    const int radius = params.kernelSize / 2;
    constexpr double kUnit = 0x1p-24; // float's unit roundoff
    RgbdFrame frame;
    cv::Mat a, b, metres;
    int frames = 0;
    double worst = 0.0, worstRatio = 0.0;
    while (frames < 4 && source->next(frame)) {
        ++frames;
        simd.filterInto(frame.depth, frame.depthScaleMetres, a);
        opencv.filterInto(frame.depth, frame.depthScaleMetres, b);
        frame.depth.convertTo(metres, CV_32F, frame.depthScaleMetres);
        // OpenCV's range table (bilateral_filter.dispatch.cpp): 4096 bins over [min, max] of its input,
        // which holds the sentinel deepest + 15 sigma where a hole is; linear interpolation of
        // f(u) = exp(-u^2 / 2 sigma^2) between nodes h apart errs by <= h^2 / 8 max |f''| <= h^2 / (8
        // sigma^2) (|f''| <= 1 / sigma^2). A weight error dw_k moves the result by exactly
        // sum dw_k (z_k - result) / W' with W' >= 1 (the centre's weight), and dw_k <= s_k (table
        // error + 1e-6: both kernels' own weight rounding and polynomial, < 5e-7 of s_k). Both
        // results carry their float sums' rounding, (2 * 29 + 1) u of the result each.
        double shallowest = 1e30, deepest = 0.0;
        bool holes = false;
        for (int v = 0; v < metres.rows; ++v)
            for (int u = 0; u < metres.cols; ++u) {
                const float z = metres.at<float>(v, u);
                if (z > 0.0f)
                    shallowest = std::min(shallowest, double(z)), deepest = std::max(deepest, double(z));
                else
                    holes = true;
            }
        ASSERT_GT(deepest, shallowest) << "frame " << frames;
        const double h = ((holes ? deepest + 15.0 * sigma : deepest) - shallowest) / 4096.0;
        const double weightError = h * h / (8.0 * sigma * sigma) + 1e-6;
        int valid = 0, changed = 0;
        for (int v = 0; v < metres.rows; ++v)
            for (int u = 0; u < metres.cols; ++u) {
                const float z0 = metres.at<float>(v, u);
                if (!(z0 > 0.0f)) {
                    EXPECT_EQ(a.at<float>(v, u), 0.0f);
                    EXPECT_EQ(b.at<float>(v, u), 0.0f);
                    continue;
                }
                ++valid;
                const double result = double(a.at<float>(v, u));
                if (std::abs(result - double(z0)) > 1e-4) ++changed;
                double spread = 0.0; // sum over valid taps of s_k |z_k - result|
                for (int i = -radius; i <= radius; ++i)
                    for (int j = -radius; j <= radius; ++j) {
                        if (std::sqrt(double(i * i + j * j)) > double(radius) || (i == 0 && j == 0)) continue;
                        const float z = metres.at<float>(std::clamp(v + i, 0, metres.rows - 1),
                                                         std::clamp(u + j, 0, metres.cols - 1));
                        if (!(z > 0.0f)) continue;
                        const double s = std::exp(-double(i * i + j * j) /
                                                  (2.0 * params.sigmaSpacePixels * params.sigmaSpacePixels));
                        spread += s * std::abs(double(z) - result);
                    }
                const double bound = weightError * spread + 2.0 * (2.0 * 29.0 + 1.0) * kUnit * result;
                const double error = std::abs(result - double(b.at<float>(v, u)));
                worst = std::max(worst, error);
                worstRatio = std::max(worstRatio, error / bound);
                if (error > bound)
                    ADD_FAILURE() << "frame " << frames << " pixel " << u << "," << v << ": " << error << " m > bound "
                                  << bound;
            }
        std::printf("frame %d: %d valid pixels, %d moved > 0.1 mm by the filter, table step h = %.3g mm\n", frames,
                    valid, changed, h * 1e3);
        EXPECT_GT(valid, 640 * 480 / 2); // real depth, mostly present
        EXPECT_GT(changed, valid / 4);   // the filter does something on it
    }
    std::printf("SIMD vs OpenCV over %d frames: worst %.3g mm, %.3f of the per-pixel bound\n", frames, worst * 1e3,
                worstRatio);
    EXPECT_EQ(frames, 4);
    EXPECT_LT(worst, 1e-4); // DepthFilter.h: "<= 0.01 mm" measured here; the bound above allows more
}

} // namespace
} // namespace lightskin::test
