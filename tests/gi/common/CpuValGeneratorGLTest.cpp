// CpuValGenerator (val_from_depth.comp on the CPU) against the GL pass, VAL by VAL, and against the
// exact geometry of analytic scenes and the double CPU reference (PCL normals), as the GL pass is
// checked in ValGeneratorGLTest.cpp.
//
// Tolerances against the GL pass (derived): both evaluate the same float operations in the same
// order; they may differ where the GPU evaluates an operation with another rounding (llvmpipe's
// division and normalize's 1/sqrt: a few ulp; the sRGB decode: GL's float pow against the exact
// value rounded to float, ~1e-7). A VAL's longest chain (gradient sum over 2R + 1 = 11 samples,
// cross product, normalisation, area) is ~40 operations deep: 40 x 2^-24 x a few ulp ~ 1e-5
// relative, and 1e-5 on the unit normal. The validity decisions (edge thresholds) compare values
// computed identically up to that rounding: the sets of depth pixels must be equal except where a
// sample sits within that rounding of a threshold, which the analytic scenes below do not hit (the
// test requires equal sets, so a changed validity rule fails it).
#include "GlTestEnvironment.h"
#include "SyntheticDepth.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/common/CpuValGenerator.h>
#include <lightskin/gi/common/ValGenerator.h>

#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <numbers>

namespace lightskin::test {
namespace {

using CpuValGeneratorGLTest = GlTest;

CameraIntrinsics camera(int width, int height) {
    CameraIntrinsics K;
    K.width = width;
    K.height = height;
    K.fx = K.fy = 525.0 * width / 640.0;
    K.cx = (width - 1) / 2.0;
    K.cy = (height - 1) / 2.0;
    return K;
}

double relative(double a, double b) { return std::abs(a - b) / std::max(std::abs(b), 1e-30); }

/// Runs both generators and checks the sets VAL by VAL (keyed by depth pixel). Returns the count.
std::size_t compareWithGl(const cv::Mat& depth, double scale, const cv::Mat& colour, const CameraIntrinsics& K,
                          const Pose& pose, const gi::ValGeneratorSettings& settings, int threads = 0) {
    gi::ValGenerator gl = gi::ValGenerator::create(depth.cols, depth.rows, settings);
    gl.generate(depth, scale, colour, K, pose);
    const std::vector<gi::VirtualAreaLight> glVals = gl.downloadVals();
    const std::vector<std::uint32_t> glPixels = gl.downloadPixelIndices();
    gi::CpuValGenerator cpu = gi::CpuValGenerator::create(depth.cols, depth.rows, settings, threads);
    const std::span<const gi::VirtualAreaLight> cpuVals = cpu.generate(depth, scale, colour, K, pose);
    const std::span<const std::uint32_t> cpuPixels = cpu.lastPixelIndices();
    EXPECT_EQ(cpuVals.size(), glVals.size()) << "stride " << settings.stride;
    std::map<std::uint32_t, std::size_t> byPixel;
    for (std::size_t k = 0; k < glPixels.size(); ++k) byPixel[glPixels[k]] = k;
    std::uint32_t previous = 0;
    for (std::size_t k = 0; k < cpuVals.size(); ++k) {
        if (k > 0) {
            EXPECT_GT(cpuPixels[k], previous) << "raster order"; // one VAL per pixel, ascending
        }
        previous = cpuPixels[k];
        const auto it = byPixel.find(cpuPixels[k]);
        if (it == byPixel.end()) {
            ADD_FAILURE() << "pixel " << cpuPixels[k] << ": a VAL on the CPU, none on GL";
            continue;
        }
        const gi::VirtualAreaLight& c = cpuVals[k];
        const gi::VirtualAreaLight& g = glVals[it->second];
        const double scaleOfScene = glm::length(glm::dvec3(g.position)) + 1.0;
        EXPECT_LT(glm::length(glm::dvec3(c.position) - glm::dvec3(g.position)), 1e-5 * scaleOfScene);
        EXPECT_LT(glm::length(glm::dvec3(c.normal) - glm::dvec3(g.normal)), 1e-5);
        EXPECT_LT(relative(c.area, g.area), 1e-5) << "pixel " << cpuPixels[k];
        for (int ch = 0; ch < 3; ++ch) EXPECT_LT(relative(c.flux[ch], g.flux[ch]), 1e-5);
        if (::testing::Test::HasFailure()) return cpuVals.size();
    }
    return cpuVals.size();
}

TEST_F(CpuValGeneratorGLTest, EqualsTheGlPassOnASphereOverATiltedFloorAtEveryStride) {
    const CameraIntrinsics K = camera(320, 240);
    cv::Mat depth, normals;
    renderDepth(K, depth, normals, SphereSurface{{-0.1, 0.05, 1.4}, 0.3},
                PlaneSurface{glm::normalize(glm::dvec3(0.0, -1.0, -0.4)), -0.8});
    depth.at<float>(100, 100) = std::numeric_limits<float>::quiet_NaN(); // holes drop their windows
    depth.at<float>(50, 200) = 0.0f;
    cv::Mat colour(K.height, K.width, CV_8UC3);
    cv::randu(colour, 0, 255);
    const Pose pose(glm::angleAxis(-0.3, glm::dvec3(0, 1, 0)), glm::dvec3(0.1, 0.2, -0.3));
    for (const int stride : {1, 2, 3, 4}) {
        gi::ValGeneratorSettings settings;
        settings.stride = stride;
        settings.exposure = 0.7f;
        const std::size_t count = compareWithGl(depth, 1.0, colour, K, pose, settings);
        // non-trivial: most of the VAL map is valid (the sphere's rim and the holes' windows are not)
        EXPECT_GT(count, std::size_t(valMapWidth(K.width, settings) * valMapHeight(K.height, settings)) / 2);
        if (HasFailure()) return;
    }
}

TEST_F(CpuValGeneratorGLTest, SixteenBitDepthWithScaleAndNegativeFy) {
    CameraIntrinsics K = camera(160, 120);
    cv::Mat depth(K.height, K.width, CV_16UC1);
    for (int v = 0; v < K.height; ++v)
        for (int u = 0; u < K.width; ++u) depth.at<std::uint16_t>(v, u) = std::uint16_t(5000 + 10 * u + 3 * v);
    depth.at<std::uint16_t>(60, 80) = 0;
    K.fy = -K.fy;
    cv::Mat colour(K.height, K.width, CV_8UC3);
    cv::randu(colour, 0, 255);
    gi::ValGeneratorSettings settings;
    settings.stride = 2;
    EXPECT_GT(compareWithGl(depth, 0.0002, colour, K, Pose{}, settings), 1000u);
}

// Rough depth: neighbours differ by up to ~1.6 x the edge threshold, so every edge rule (cross,
// border walk, the even stride's 2x2 block with its doubled diagonal step) decides for many VALs.
TEST_F(CpuValGeneratorGLTest, EqualsTheGlPassWhereTheEdgeRulesDecide) {
    const CameraIntrinsics K = camera(160, 120);
    cv::Mat noise(K.height, K.width, CV_32FC1);
    cv::RNG rng(18);
    rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.6 * 0.03);
    const cv::Mat depth = 1.0 + noise; // metres; threshold maxDepthChange * z ~ 0.03 m
    cv::Mat colour(K.height, K.width, CV_8UC3, cv::Scalar(10, 100, 250));
    for (const int stride : {1, 2}) {
        gi::ValGeneratorSettings settings;
        settings.stride = stride;
        settings.normalWindowRadius = 1;
        const std::size_t count = compareWithGl(depth, 1.0, colour, K, Pose{}, settings);
        const std::size_t cells = std::size_t(valMapWidth(K.width, settings) * valMapHeight(K.height, settings));
        EXPECT_GT(count, cells / 50) << "stride " << stride; // both outcomes occur
        EXPECT_LT(count, cells / 2) << "stride " << stride;
        if (HasFailure()) return;
    }
}

TEST_F(CpuValGeneratorGLTest, OutputDoesNotDependOnTheThreadCount) {
    const CameraIntrinsics K = camera(160, 120);
    cv::Mat depth, normals;
    renderDepth(K, depth, normals, SphereSurface{{0.0, 0.0, 1.0}, 0.25}, PlaneSurface{{0, 0, -1}, -1.5});
    cv::Mat colour(K.height, K.width, CV_8UC3);
    cv::randu(colour, 0, 255);
    std::vector<gi::VirtualAreaLight> first;
    for (const int threads : {1, 2, 3}) {
        gi::CpuValGenerator cpu = gi::CpuValGenerator::create(K.width, K.height, {}, threads);
        const auto vals = cpu.generate(depth, 1.0, colour, K, Pose{});
        ASSERT_GT(vals.size(), 1000u);
        if (first.empty()) {
            first.assign(vals.begin(), vals.end());
            continue;
        }
        ASSERT_EQ(vals.size(), first.size());
        EXPECT_EQ(std::memcmp(vals.data(), first.data(), vals.size_bytes()), 0) << threads << " threads";
    }
}

// Against the exact geometry: a fronto-parallel plane's VALs tile the plane patch the blocks see
// (ValGeneratorGLTest's closed form), normals exactly -z, flux = pi exposure linear colour area.
TEST_F(CpuValGeneratorGLTest, FrontoParallelPlaneMatchesTheClosedForm) {
    const CameraIntrinsics K = camera(160, 120);
    const double z = 1.3;
    cv::Mat depth, normals;
    renderDepth(K, depth, normals, PlaneSurface{{0, 0, -1}, -z});
    const cv::Mat colour(K.height, K.width, CV_8UC3, cv::Scalar(40, 120, 200));
    gi::ValGeneratorSettings settings;
    settings.stride = 2;
    settings.exposure = 2.0f;
    gi::CpuValGenerator cpu = gi::CpuValGenerator::create(K.width, K.height, settings);
    const auto vals = cpu.generate(depth, 1.0, colour, K, Pose{});
    ASSERT_FALSE(vals.empty());
    const double blockArea = (2.0 * z / K.fx) * (2.0 * z / K.fy);
    double total = 0.0;
    for (const auto& val : vals) {
        EXPECT_NEAR(val.normal.z, -1.0f, 1e-6f);
        // a = footprint cos(alpha) / cos(theta) = footprint on a fronto-parallel plane (theta = alpha)
        EXPECT_NEAR(double(val.area) / blockArea, 1.0, 1e-5);
        const double linear[3] = {gi::srgbToLinear(200.0 / 255.0), gi::srgbToLinear(120.0 / 255.0),
                                  gi::srgbToLinear(40.0 / 255.0)};
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(double(val.flux[c]) / (std::numbers::pi * 2.0 * linear[c] * double(val.area)), 1.0, 1e-5);
        total += double(val.area);
    }
    EXPECT_NEAR(total / (blockArea * double(vals.size())), 1.0, 1e-5);
}

TEST_F(CpuValGeneratorGLTest, RejectsBadInputs) {
    gi::CpuValGenerator cpu = gi::CpuValGenerator::create(64, 48);
    const cv::Mat colour(48, 64, CV_8UC3, cv::Scalar::all(0));
    EXPECT_THROW(cpu.generate(cv::Mat(48, 64, CV_8UC1), 1.0, colour, camera(64, 48), Pose{}), Error);
    EXPECT_THROW(cpu.generate(cv::Mat(47, 64, CV_32FC1), 1.0, colour, camera(64, 48), Pose{}), Error);
    EXPECT_THROW(cpu.generate(cv::Mat(48, 64, CV_32FC1), 1.0, cv::Mat(48, 64, CV_8UC4), camera(64, 48), Pose{}), Error);
    EXPECT_THROW(gi::CpuValGenerator::create(0, 48), Error);
    EXPECT_THROW(gi::CpuValGenerator::create(64, 48, {}, -1), Error);
    gi::ValGeneratorSettings bad;
    bad.stride = 0;
    EXPECT_THROW(gi::CpuValGenerator::create(64, 48, bad), Error);
}

} // namespace
} // namespace lightskin::test
