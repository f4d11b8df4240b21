// ValGenerator against its PCL reference on real Kinect data: PCL's organised
// table_scene_mug_stereo_textured.pcd (640x480; see tests/data/rgbd-kinect-v1-pcl/PCL_LICENSE.txt).
#include "GlTestEnvironment.h"
#include "TestPaths.h"

#include <lightskin/gi/common/ValGenerator.h>
#include <lightskin/gi/reference/ValGeneratorReference.h>

#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cmath>
#include <numbers>
#include <unordered_map>

namespace lightskin::test {
namespace {

using ValGeneratorDataGLTest = GlTest;

struct RgbdFromCloud {
    cv::Mat depth;  // CV_32FC1 metres, NaN missing
    cv::Mat colour; // CV_8UC3 BGR
    CameraIntrinsics intrinsics;
    double worstReprojectionPixels = 0.0; // of the cloud's points under the fitted intrinsics
};

// The cloud stores x, y, z per pixel; pinhole intrinsics follow from u = fx x/z + cx (least squares).
RgbdFromCloud loadCloud() {
    pcl::PointCloud<pcl::PointXYZRGBA> cloud;
    const std::string path = dataPath("rgbd-kinect-v1-pcl/table_scene_mug_stereo_textured.pcd").string();
    if (pcl::io::loadPCDFile(path, cloud) != 0) throw std::runtime_error("cannot read " + path);
    RgbdFromCloud out;
    const int width = int(cloud.width), height = int(cloud.height);
    out.depth.create(height, width, CV_32FC1);
    out.colour.create(height, width, CV_8UC3);
    double su = 0, sx = 0, sxx = 0, sxu = 0, sv = 0, sy = 0, syy = 0, syv = 0;
    double n = 0;
    for (int v = 0; v < height; ++v)
        for (int u = 0; u < width; ++u) {
            const pcl::PointXYZRGBA& p = cloud.at(u, v);
            out.colour.at<cv::Vec3b>(v, u) = cv::Vec3b(p.b, p.g, p.r);
            const bool valid = std::isfinite(p.z) && p.z > 0.0f;
            out.depth.at<float>(v, u) = valid ? p.z : std::numeric_limits<float>::quiet_NaN();
            if (!valid) continue;
            const double x = double(p.x) / double(p.z), y = double(p.y) / double(p.z);
            su += u, sx += x, sxx += x * x, sxu += x * u, sv += v, sy += y, syy += y * y, syv += y * v, n += 1;
        }
    CameraIntrinsics& K = out.intrinsics;
    K.width = width;
    K.height = height;
    K.fx = (n * sxu - sx * su) / (n * sxx - sx * sx);
    K.cx = (su - K.fx * sx) / n;
    K.fy = (n * syv - sy * sv) / (n * syy - sy * sy);
    K.cy = (sv - K.fy * sy) / n;
    for (int v = 0; v < height; ++v)
        for (int u = 0; u < width; ++u) {
            const pcl::PointXYZRGBA& p = cloud.at(u, v);
            if (!(std::isfinite(p.z) && p.z > 0.0f)) continue;
            const glm::dvec2 projected = K.project({p.x, p.y, p.z});
            out.worstReprojectionPixels =
                std::max({out.worstReprojectionPixels, std::abs(projected.x - u), std::abs(projected.y - v)});
        }
    return out;
}

double angleDegrees(glm::dvec3 a, glm::dvec3 b) {
    return std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0)) * 180.0 / std::numbers::pi;
}

TEST_F(ValGeneratorDataGLTest, GpuNormalsAgreeWithPclOnRealKinectDepth) {
    const RgbdFromCloud frame = loadCloud();
    // The cloud is a pinhole image: the fitted intrinsics must reproduce every pixel position.
    const CameraIntrinsics& K = frame.intrinsics;
    std::printf("fitted intrinsics fx %.3f fy %.3f cx %.3f cy %.3f\n", K.fx, K.fy, K.cx, K.cy);
    ASSERT_LT(frame.worstReprojectionPixels, 0.05);
    const Pose pose(glm::angleAxis(0.2, glm::dvec3(1, 0, 0)), glm::dvec3(0.0, 1.0, 0.0));
    for (int stride : {1, 4}) {
        gi::ValGeneratorSettings settings;
        settings.stride = stride;
        gi::ValGenerator generator = gi::ValGenerator::create(frame.depth.cols, frame.depth.rows, settings);
        generator.generate(frame.depth, 1.0, frame.colour, frame.intrinsics, pose);
        const auto vals = generator.downloadVals();
        const auto pixels = generator.downloadPixelIndices();
        const auto reference =
            gi::generateValsReference(frame.depth, 1.0, frame.colour, frame.intrinsics, pose, settings);
        std::unordered_map<std::uint32_t, std::size_t> byPixel;
        for (std::size_t k = 0; k < reference.size(); ++k) byPixel[reference[k].pixelIndex] = k;
        double angleSum = 0.0, fluxGpu = 0.0, fluxCpu = 0.0;
        std::size_t both = 0;
        for (std::size_t k = 0; k < vals.size(); ++k) {
            const auto it = byPixel.find(pixels[k]);
            if (it == byPixel.end()) continue;
            const gi::ReferenceVal& r = reference[it->second];
            ++both;
            angleSum += angleDegrees(glm::dvec3(vals[k].normal), r.normal);
            fluxGpu += double(vals[k].flux.g);
            fluxCpu += r.flux.g;
            ASSERT_LT(glm::length(glm::dvec3(vals[k].position) - r.position), 1e-4);
        }
        if (stride == 1) {
            // Independent check of the reference's PCL set-up: PCL's own normal-estimation test on this
            // cloud (AVERAGE_3D_GRADIENT, max depth change 0.02, smoothing 10) finds 183,855 normals.
            EXPECT_EQ(reference.size(), 183855u);
        }
        const double meanAngle = angleSum / double(both);
        std::printf("stride %d: GPU %zu VALs, reference %zu, both %zu, mean angle %.3f deg, flux ratio %.4f\n", stride,
                    vals.size(), reference.size(), both, meanAngle, fluxGpu / fluxCpu);
        // The scene is mostly valid: most VALs are valid in both (the GPU's edge test is stricter).
        EXPECT_GT(double(both), 0.75 * double(reference.size()));
        EXPECT_LE(meanAngle, 3.0) << "stride " << stride; // the agreement criterion
        // Same normals within a few degrees give the same areas, hence the same flux, on average.
        EXPECT_NEAR(fluxGpu / fluxCpu, 1.0, 0.03);
    }
}

// Halving or doubling the VAL resolution keeps the emitted light: the summed flux (and area) of a
// real frame changes by <= 2 % between strides 1, 2 and 4 (the gather's stride invariance builds on it).
TEST_F(ValGeneratorDataGLTest, TotalFluxIsStrideInvariantOnRealDepth) {
    const RgbdFromCloud frame = loadCloud();
    glm::dvec3 flux[3];
    double area[3] = {};
    int i = 0;
    for (int stride : {1, 2, 4}) {
        gi::ValGeneratorSettings settings;
        settings.stride = stride;
        gi::ValGenerator generator = gi::ValGenerator::create(frame.depth.cols, frame.depth.rows, settings);
        generator.generate(frame.depth, 1.0, frame.colour, frame.intrinsics, Pose{});
        flux[i] = glm::dvec3(0.0);
        for (const auto& val : generator.downloadVals()) flux[i] += glm::dvec3(val.flux), area[i] += double(val.area);
        ++i;
    }
    std::printf("total area %.4f / %.4f / %.4f m^2, green flux %.4f / %.4f / %.4f\n", area[0], area[1], area[2],
                flux[0].g, flux[1].g, flux[2].g);
    for (int k = 1; k < 3; ++k) {
        EXPECT_NEAR(area[k] / area[0], 1.0, 0.02) << k;
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(flux[k][c] / flux[0][c], 1.0, 0.02) << k << " " << c;
    }
}

} // namespace
} // namespace lightskin::test
