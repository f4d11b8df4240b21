// ValGenerator on the GPU against analytic scenes (exact normals, areas, flux) and against its
// double CPU reference (PCL normals).
#include "GlTestEnvironment.h"
#include "SyntheticDepth.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/common/ValGenerator.h>
#include <lightskin/gi/reference/ValGeneratorReference.h>

#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <map>
#include <numbers>

namespace lightskin::test {
namespace {

using ValGeneratorGLTest = GlTest;
using gi::ValGenerator;
using gi::ValGeneratorSettings;

CameraIntrinsics smallCamera(int width = 160, int height = 120) {
    CameraIntrinsics K;
    K.width = width;
    K.height = height;
    K.fx = K.fy = 525.0 * width / 640.0;
    K.cx = (width - 1) / 2.0;
    K.cy = (height - 1) / 2.0;
    return K;
}

cv::Mat uniformColour(int width, int height, cv::Vec3b bgr) {
    return cv::Mat(height, width, CV_8UC3, cv::Scalar(bgr[0], bgr[1], bgr[2]));
}

double angleDegrees(glm::dvec3 a, glm::dvec3 b) {
    return std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0)) * 180.0 / std::numbers::pi;
}

struct GpuRun {
    std::vector<gi::VirtualAreaLight> vals;
    std::vector<std::uint32_t> pixels;
};

GpuRun runGpu(const cv::Mat& depth, const cv::Mat& colour, const CameraIntrinsics& K, const Pose& pose,
              const ValGeneratorSettings& settings, double scale = 1.0) {
    ValGenerator generator = ValGenerator::create(depth.cols, depth.rows, settings);
    const gi::ValSetView set = generator.generate(depth, scale, colour, K, pose);
    GpuRun run{generator.downloadVals(), generator.downloadPixelIndices()};
    EXPECT_EQ(set.count, run.vals.size());
    EXPECT_NE(set.buffer, 0u);
    return run;
}

void expectFinite(const gi::VirtualAreaLight& val) {
    for (int k = 0; k < 3; ++k) {
        ASSERT_TRUE(std::isfinite(val.position[k]) && std::isfinite(val.normal[k]) && std::isfinite(val.flux[k]));
        ASSERT_GE(val.flux[k], 0.0f);
    }
    ASSERT_TRUE(std::isfinite(val.area) && val.area > 0.0f);
    ASSERT_NEAR(glm::length(val.normal), 1.0f, 1e-4f);
}

// A fronto-parallel plane fills the image: the VALs tile a rectangle of pixel blocks, and their
// areas sum to the plane patch those blocks see, ((block columns * s) z / fx) ((rows * s) z / fy).
TEST_F(ValGeneratorGLTest, FrontoParallelPlaneAreasSumToThePatchArea) {
    const CameraIntrinsics K = smallCamera();
    const double z = 1.7;
    cv::Mat depth, normals;
    renderDepth(K, depth, normals, PlaneSurface{{0, 0, -1}, -z});
    // Strides 1..4 stage depth in shared memory; stride 8 (tile 7 * 8 + 11 > 64) uses texel fetches.
    for (int stride : {1, 2, 3, 4, 8}) {
        ValGeneratorSettings settings;
        settings.stride = stride;
        const GpuRun run = runGpu(depth, uniformColour(K.width, K.height, {128, 128, 128}), K, Pose{}, settings);
        // Expected blocks: centre c = i*s + s/2 with the (2R+1) window inside the image.
        const int R = settings.normalWindowRadius;
        int columns = 0, rows = 0;
        for (int i = 0; i < K.width / stride; ++i)
            columns += (i * stride + stride / 2 - R >= 0 && i * stride + stride / 2 + R < K.width);
        for (int j = 0; j < K.height / stride; ++j)
            rows += (j * stride + stride / 2 - R >= 0 && j * stride + stride / 2 + R < K.height);
        ASSERT_EQ(run.vals.size(), std::size_t(columns * rows)) << "stride " << stride;
        double total = 0.0;
        for (const auto& val : run.vals) {
            expectFinite(val);
            EXPECT_NEAR(val.position.z, z, 1e-5);
            EXPECT_LT(angleDegrees(glm::dvec3(val.normal), {0, 0, -1}), 0.01);
            total += double(val.area);
        }
        const double expected = (columns * stride * z / K.fx) * (rows * stride * z / K.fy);
        // Float accumulation of ~20k terms in double, each exact to float rounding: 1e-5 relative.
        EXPECT_NEAR(total / expected, 1.0, 1e-5) << "stride " << stride;
    }
}

// Tilted plane: the summed differential areas approach the true area of the quadrilateral the
// covered pixel rectangle cuts out of the plane (corner rays intersected with the plane).
TEST_F(ValGeneratorGLTest, TiltedPlaneAreasSumToTheTrueSurfaceArea) {
    const CameraIntrinsics K = smallCamera();
    for (double tiltDegrees : {30.0, 60.0, 75.0}) {
        const double tilt = tiltDegrees * std::numbers::pi / 180.0;
        const PlaneSurface plane{glm::normalize(glm::dvec3(std::sin(tilt), 0.0, -std::cos(tilt))),
                                 -1.5 * std::cos(tilt)};
        cv::Mat depth, normals;
        renderDepth(K, depth, normals, plane);
        for (int stride : {1, 4}) {
            ValGeneratorSettings settings;
            settings.stride = stride;
            const GpuRun run = runGpu(depth, uniformColour(K.width, K.height, {200, 200, 200}), K, Pose{}, settings);
            ASSERT_FALSE(run.vals.empty());
            int uMin = K.width, uMax = -1, vMin = K.height, vMax = -1;
            double total = 0.0, worstAngle = 0.0;
            for (std::size_t k = 0; k < run.vals.size(); ++k) {
                expectFinite(run.vals[k]);
                const int u = int(run.pixels[k]) % K.width, v = int(run.pixels[k]) / K.width;
                uMin = std::min(uMin, u), uMax = std::max(uMax, u), vMin = std::min(vMin, v), vMax = std::max(vMax, v);
                total += double(run.vals[k].area);
                worstAngle = std::max(worstAngle, angleDegrees(glm::dvec3(run.vals[k].normal), plane.normal));
            }
            const int columns = (uMax - uMin) / stride + 1, rows = (vMax - vMin) / stride + 1;
            ASSERT_EQ(run.vals.size(), std::size_t(columns * rows)) << "holes in a continuous plane";
            EXPECT_LT(worstAngle, 0.05) << tiltDegrees;
            // Pixel block edges: block i spans [i*s - 0.5, i*s + s - 0.5] around pixel centres.
            const double u0 = uMin - stride / 2 - 0.5, u1 = uMax - stride / 2 + stride - 0.5;
            const double v0 = vMin - stride / 2 - 0.5, v1 = vMax - stride / 2 + stride - 0.5;
            const auto corner = [&](double u, double v) {
                const glm::dvec3 r = pixelRay(K, u, v);
                return r * *plane.hit(r);
            };
            const glm::dvec3 a = corner(u0, v0), b = corner(u1, v0), c = corner(u1, v1), d = corner(u0, v1);
            const double quadArea = 0.5 * glm::length(glm::cross(c - a, d - b));
            // Tolerance: each VAL is the first-order (midpoint) area of its block; the midpoint rule's
            // error is second order in the relative depth change across a block, (s tan(tilt) / f)^2:
            // (4 * 3.7 / 131)^2 = 1.3 % at s = 4, 75 deg, of which a fraction survives (measured 0.23 %).
            const double tolerance = stride == 1 ? 2e-4 : 5e-3;
            EXPECT_NEAR(total / quadArea, 1.0, tolerance) << "tilt " << tiltDegrees << " stride " << stride;
        }
    }
}

TEST_F(ValGeneratorGLTest, FluxIsPiTimesExposureTimesLinearColourTimesArea) {
    const CameraIntrinsics K = smallCamera();
    cv::Mat depth, normals;
    renderDepth(K, depth, normals, PlaneSurface{glm::normalize(glm::dvec3(0.3, -0.2, -1.0)), -1.0});
    ValGeneratorSettings settings;
    settings.exposure = 2.5f;
    settings.stride = 2;
    const cv::Vec3b bgr(10, 128, 250);
    const GpuRun run = runGpu(depth, uniformColour(K.width, K.height, bgr), K, Pose{}, settings);
    ASSERT_GT(run.vals.size(), 1000u);
    const glm::dvec3 linear(gi::srgbToLinear(250 / 255.0), gi::srgbToLinear(128 / 255.0), gi::srgbToLinear(10 / 255.0));
    EXPECT_NEAR(linear.g, 0.2158605, 1e-6); // published sRGB value of 128
    for (const auto& val : run.vals) {
        const glm::dvec3 expected = std::numbers::pi * 2.5 * linear * double(val.area);
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(double(val.flux[k]) / expected[k], 1.0, 1e-5) << k; // float rounding
    }
}

// A sphere before a wall: normals agree with the exact ones; VALs never straddle the silhouette.
TEST_F(ValGeneratorGLTest, SphereNormalsMatchTheAnalyticNormalsAndEdgesAreDropped) {
    const CameraIntrinsics K = smallCamera(320, 240);
    const SphereSurface sphere{{0.05, -0.02, 1.2}, 0.25};
    const PlaneSurface wall{{0, 0, -1}, -2.0};
    cv::Mat depth, normals;
    renderDepth(K, depth, normals, sphere, wall);
    ValGeneratorSettings settings;
    const Pose world_T_camera(glm::angleAxis(0.4, glm::normalize(glm::dvec3(1, 2, 3))), glm::dvec3(0.5, -1.0, 2.0));
    const GpuRun run = runGpu(depth, uniformColour(K.width, K.height, {90, 90, 90}), K, world_T_camera, settings);
    double sphereSum = 0.0;
    int sphereCount = 0, wallCount = 0;
    for (std::size_t k = 0; k < run.vals.size(); ++k) {
        expectFinite(run.vals[k]);
        const int u = int(run.pixels[k]) % K.width, v = int(run.pixels[k]) / K.width;
        const cv::Vec3d n = normals.at<cv::Vec3d>(v, u);
        const glm::dvec3 exactWorld = world_T_camera.transformDirection({n[0], n[1], n[2]});
        const double angle = angleDegrees(glm::dvec3(run.vals[k].normal), exactWorld);
        const glm::dvec3 p = pixelRay(K, u, v) * double(depth.at<float>(v, u));
        const glm::dvec3 positionWorld = world_T_camera.transformPoint(p);
        EXPECT_LT(glm::length(glm::dvec3(run.vals[k].position) - positionWorld), 1e-5);
        if (std::abs(glm::length(p - sphere.centre) - sphere.radius) < 1e-6) {
            sphereSum += angle, ++sphereCount;
        } else {
            ++wallCount;
            // No smeared normals: a wall VAL next to the silhouette would tilt toward the sphere.
            EXPECT_LT(angle, 0.05);
        }
    }
    ASSERT_GT(sphereCount, 5000);
    ASSERT_GT(wallCount, 30000);
    // The window averages the gradient over +-5 px, i.e. over +-5 degrees of arc on this sphere
    // (5 px * 1.2 m / 262 px = 2.3 cm on a 25 cm radius); perspective makes that average slightly
    // asymmetric, so the mean error is a fraction of the arc: bound 1 degree.
    EXPECT_LT(sphereSum / sphereCount, 1.0);
}

TEST_F(ValGeneratorGLTest, AgreesWithTheCpuReferenceOnSyntheticDepth) {
    const CameraIntrinsics K = smallCamera(320, 240);
    const SphereSurface sphere{{-0.1, 0.05, 1.4}, 0.3};
    const PlaneSurface floor{glm::normalize(glm::dvec3(0.0, -1.0, -0.4)), -0.8};
    cv::Mat depth, normals;
    renderDepth(K, depth, normals, sphere, floor);
    cv::Mat colour(K.height, K.width, CV_8UC3);
    cv::randu(colour, 0, 255);
    ValGeneratorSettings settings;
    settings.stride = 2;
    settings.exposure = 0.7f;
    const Pose pose(glm::angleAxis(-0.3, glm::dvec3(0, 1, 0)), glm::dvec3(0.1, 0.2, -0.3));
    const GpuRun run = runGpu(depth, colour, K, pose, settings);
    const std::vector<gi::ReferenceVal> reference = gi::generateValsReference(depth, 1.0, colour, K, pose, settings);
    std::map<std::uint32_t, const gi::ReferenceVal*> byPixel;
    for (const auto& r : reference) byPixel[r.pixelIndex] = &r;
    double angleSum = 0.0;
    int both = 0;
    for (std::size_t k = 0; k < run.vals.size(); ++k) {
        const auto it = byPixel.find(run.pixels[k]);
        if (it == byPixel.end()) continue;
        const gi::ReferenceVal& r = *it->second;
        const gi::VirtualAreaLight& g = run.vals[k];
        ++both;
        const double angle = angleDegrees(glm::dvec3(g.normal), r.normal);
        angleSum += angle;
        EXPECT_LT(glm::length(glm::dvec3(g.position) - r.position), 1e-5);
        // a = footprint cos(alpha) / max(cos(theta), minCosine): the two normal estimators differ
        // by `angle`, so the areas differ by the ratio of their cos(theta) (up to tan(theta) x angle,
        // 2.4 % at 70 degrees and 0.5 degrees). Divided out, the rest is float rounding of the
        // footprint (~10 operations, 1e-6) and of the cosines near the clamp: 1e-4.
        const glm::dvec3 ray = glm::normalize(glm::dvec3(g.position) - pose.translation());
        const double cosG = std::max(-glm::dot(glm::dvec3(g.normal), ray), double(settings.minCosine));
        const double cosR = std::max(-glm::dot(r.normal, ray), double(settings.minCosine));
        EXPECT_NEAR(double(g.area) / r.area * (cosG / cosR), 1.0, 1e-4);
        // flux = pi exposure colour area: per unit area the two differ only in decoding the same
        // 8-bit sRGB byte (GL sRGB texture vs the exact formula; Mesa decodes through a float
        // table, exact to float: 1e-6) and float rounding of the product: 1e-5
        for (int c = 0; c < 3; ++c)
            if (r.flux[c] > 1e-3 * r.area) {
                EXPECT_NEAR(double(g.flux[c]) / double(g.area) / (r.flux[c] / r.area), 1.0, 1e-5);
            }
    }
    ASSERT_GT(both, int(reference.size() * 8 / 10));
    EXPECT_LE(angleSum / both, 3.0);
}

// Missing depth (0 and NaN) and edges never produce a VAL, and nothing else is lost.
TEST_F(ValGeneratorGLTest, MissingDepthMakesNoValAndNoNonFiniteOutput) {
    const CameraIntrinsics K = smallCamera();
    cv::Mat depth, normals;
    renderDepth(K, depth, normals, PlaneSurface{{0, 0, -1}, -1.0});
    const int holeU = 80, holeV = 60, zeroU = 40, zeroV = 30;
    depth.at<float>(holeV, holeU) = std::numeric_limits<float>::quiet_NaN();
    depth.at<float>(zeroV, zeroU) = 0.0f;
    depth.at<float>(100, 130) = std::numeric_limits<float>::infinity();
    depth.at<float>(10, 10) = -1.0f;
    ValGeneratorSettings settings;
    const int R = settings.normalWindowRadius;
    const GpuRun run = runGpu(depth, uniformColour(K.width, K.height, {50, 60, 70}), K, Pose{}, settings);
    // Expected: every centre whose window fits and whose cross or border walk avoids the bad pixels.
    const auto sees = [&](int cu, int cv, int u, int v) {
        const int du = u - cu, dv = v - cv;
        if (std::abs(du) > R || std::abs(dv) > R) return false;
        return du == 0 || dv == 0 || std::abs(du) == R || std::abs(dv) == R;
    };
    std::size_t expected = 0;
    for (int v = R; v < K.height - R; ++v)
        for (int u = R; u < K.width - R; ++u)
            expected +=
                !(sees(u, v, holeU, holeV) || sees(u, v, zeroU, zeroV) || sees(u, v, 130, 100) || sees(u, v, 10, 10));
    EXPECT_EQ(run.vals.size(), expected);
    for (std::size_t k = 0; k < run.vals.size(); ++k) {
        expectFinite(run.vals[k]);
        EXPECT_NE(run.pixels[k], std::uint32_t(holeV * K.width + holeU));
        EXPECT_NE(run.pixels[k], std::uint32_t(zeroV * K.width + zeroU));
    }
}

TEST_F(ValGeneratorGLTest, AllMissingDepthGivesAnEmptySet) {
    const CameraIntrinsics K = smallCamera();
    const cv::Mat depth = cv::Mat::zeros(K.height, K.width, CV_16UC1);
    const GpuRun run = runGpu(depth, uniformColour(K.width, K.height, {1, 2, 3}), K, Pose{}, {}, 0.001);
    EXPECT_TRUE(run.vals.empty());
}

TEST_F(ValGeneratorGLTest, SixteenBitDepthUsesTheScale) {
    const CameraIntrinsics K = smallCamera();
    const cv::Mat depth(K.height, K.width, CV_16UC1, cv::Scalar(6000)); // 1.2 m at TUM's 5000 = 1 m
    const GpuRun run = runGpu(depth, uniformColour(K.width, K.height, {1, 2, 3}), K, Pose{}, {}, 0.0002);
    ASSERT_FALSE(run.vals.empty());
    for (const auto& val : run.vals) EXPECT_NEAR(val.position.z, 1.2f, 1e-6f);
}

// Grazing surfaces: the area clamp bounds a by footprint * cos(alpha) / minCosine.
TEST_F(ValGeneratorGLTest, GrazingAnglesAreClampedAndFinite) {
    const CameraIntrinsics K = smallCamera();
    const double tilt = 86.0 * std::numbers::pi / 180.0;
    const PlaneSurface plane{glm::normalize(glm::dvec3(0.0, std::sin(tilt), -std::cos(tilt))), -1.0 * std::cos(tilt)};
    cv::Mat depth, normals;
    renderDepth(K, depth, normals, plane);
    ValGeneratorSettings settings;
    settings.maxDepthChange = 0.2f; // keep the grazing plane (adjacent rows differ by ~11 %)
    const GpuRun run = runGpu(depth, uniformColour(K.width, K.height, {255, 255, 255}), K, Pose{}, settings);
    ASSERT_GT(run.vals.size(), 100u);
    int clamped = 0;
    for (const auto& val : run.vals) {
        expectFinite(val);
        const glm::dvec3 p(val.position);
        const double footprint = (p.z / K.fx) * (p.z / K.fy);
        const double cosAlpha = p.z / glm::length(p);
        const double cosTheta = std::abs(glm::dot(glm::normalize(p), plane.normal));
        const double bound = footprint * cosAlpha / double(settings.minCosine);
        EXPECT_LE(double(val.area), bound * (1 + 1e-4));
        if (cosTheta < double(settings.minCosine)) {
            ++clamped;
            EXPECT_NEAR(double(val.area) / bound, 1.0, 1e-3);
        }
    }
    EXPECT_GT(clamped, 100);
}

// Scene scale 1e-3 m .. 1e3 m: the same image at a scaled depth scales areas by scale^2.
TEST_F(ValGeneratorGLTest, SceneScaleFromMillimetresToKilometres) {
    const CameraIntrinsics K = smallCamera();
    for (double scale : {1e-3, 1.0, 1e3}) {
        const PlaneSurface plane{glm::normalize(glm::dvec3(0.2, 0.1, -1.0)), -scale};
        cv::Mat depth, normals;
        renderDepth(K, depth, normals, plane);
        const GpuRun run = runGpu(depth, uniformColour(K.width, K.height, {128, 128, 128}), K, Pose{}, {});
        ASSERT_GT(run.vals.size(), 10000u) << scale;
        double total = 0.0;
        for (const auto& val : run.vals) {
            expectFinite(val);
            EXPECT_LT(angleDegrees(glm::dvec3(val.normal), plane.normal), 0.1) << scale;
            total += double(val.area);
        }
        EXPECT_GT(total, 0.0);
        static double unitTotal = 0.0;
        if (scale == 1e-3) {
            unitTotal = total / (scale * scale);
        } else {
            EXPECT_NEAR(total / (scale * scale) / unitTotal, 1.0, 1e-4) << scale;
        }
    }
}

// ICL-NUIM's negative fy (y up in the image) flips the back-projection; VALs must still face the
// camera and keep their areas. Also covers the RgbdFrame overload (16-bit depth, registered).
TEST_F(ValGeneratorGLTest, NegativeFyAndRgbdFrameInput) {
    CameraIntrinsics K = smallCamera();
    RgbdFrame frame;
    frame.depth = cv::Mat(K.height, K.width, CV_16UC1, cv::Scalar(1500));
    frame.depthScaleMetres = 0.001;
    frame.colour = uniformColour(K.width, K.height, {20, 40, 60});
    std::vector<double> totals;
    for (double sign : {1.0, -1.0}) {
        K.fy = sign * std::abs(K.fy);
        frame.depthIntrinsics = frame.colourIntrinsics = K;
        ValGenerator generator = ValGenerator::create(K.width, K.height);
        generator.generate(frame, Pose{});
        double total = 0.0;
        for (const auto& val : generator.downloadVals()) {
            expectFinite(val);
            EXPECT_LT(angleDegrees(glm::dvec3(val.normal), {0, 0, -1}), 0.01);
            total += double(val.area);
        }
        totals.push_back(total);
    }
    EXPECT_GT(totals[0], 0.0);
    EXPECT_NEAR(totals[1] / totals[0], 1.0, 1e-6);
    frame.registration = DepthRegistration::Unregistered;
    ValGenerator generator = ValGenerator::create(K.width, K.height);
    EXPECT_THROW(generator.generate(frame, Pose{}), Error);
}

TEST_F(ValGeneratorGLTest, RejectsBadInputs) {
    ValGeneratorSettings bad;
    bad.stride = 0;
    EXPECT_THROW(ValGenerator::create(64, 48, bad), Error);
    ValGenerator generator = ValGenerator::create(64, 48);
    const cv::Mat colour = uniformColour(64, 48, {1, 1, 1});
    EXPECT_THROW(generator.generate(cv::Mat::zeros(48, 64, CV_8UC1), 1.0, colour, smallCamera(64, 48), Pose{}), Error);
    EXPECT_THROW(generator.generate(cv::Mat::zeros(40, 64, CV_32FC1), 1.0, colour, smallCamera(64, 48), Pose{}), Error);
    EXPECT_THROW(generator.generate(cv::Mat::zeros(48, 64, CV_32FC1), 1.0, colour, CameraIntrinsics{}, Pose{}), Error);
}

} // namespace
} // namespace lightskin::test
