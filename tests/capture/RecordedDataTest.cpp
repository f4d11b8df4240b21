// Recorded real data through openFrameSource: TUM RGB-D (fr2/desk), ICL-NUIM with its
// ground-truth trajectory, PCL's Kinect TIFF frames. Data: tests/data/*/README.md.
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace lightskin::test {
namespace {

bool identical(const cv::Mat& a, const cv::Mat& b) {
    return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

double median(std::vector<double> values) {
    if (values.empty()) return std::nan("");
    std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(values.size() / 2), values.end());
    return values[values.size() / 2];
}

TEST(RecordedDataTest, TumFreiburg2FramesAreDeliveredUnchanged) {
    capture::FrameSourceOptions options;
    options.intrinsics = CameraIntrinsics::tumFreiburg2();
    const auto folder = dataPath("tum-fr2-desk");
    auto source = capture::openFrameSource(folder.string(), options);
    ASSERT_EQ(source->frameCount(), 2);
    RgbdFrame frame;
    for (int i = 1; i <= 2; ++i) {
        ASSERT_TRUE(source->next(frame));
        EXPECT_TRUE(
            identical(frame.colour, cv::imread((folder / (std::to_string(i) + ".png")).string(), cv::IMREAD_COLOR)));
        EXPECT_TRUE(identical(
            frame.depth, cv::imread((folder / (std::to_string(i) + "_depth.png")).string(), cv::IMREAD_UNCHANGED)));
        EXPECT_NEAR(frame.depthTimestampSeconds - frame.colourTimestampSeconds, 0.005, 1e-6);
        EXPECT_DOUBLE_EQ(frame.colourIntrinsics.fx, 520.9);
        EXPECT_NO_THROW(frame.validate("tum"));
        // A desk scene seen by a Kinect: most depth valid, median between 0.5 and 3 m.
        std::vector<double> metres;
        for (int v = 0; v < frame.depth.rows; v += 4)
            for (int u = 0; u < frame.depth.cols; u += 4)
                if (frame.depth.at<std::uint16_t>(v, u) != 0) metres.push_back(frame.depthMetresAt(u, v));
        EXPECT_GT(double(metres.size()), 0.5 * (640 / 4) * (480 / 4));
        EXPECT_GT(median(metres), 0.5);
        EXPECT_LT(median(metres), 3.0);
    }
    EXPECT_FALSE(source->next(frame));
}

/// Median |z predicted - z measured| when frame a's depth is moved into frame b with the poses.
double reprojectionResidual(const RgbdFrame& a, const RgbdFrame& b, const Pose& world_T_a, const Pose& world_T_b) {
    const Pose b_T_a = world_T_b.inverse() * world_T_a;
    std::vector<double> residuals;
    for (int v = 0; v < a.depth.rows; v += 3)
        for (int u = 0; u < a.depth.cols; u += 3) {
            const double z = a.depthMetresAt(u, v);
            if (z <= 0.0) continue;
            const glm::dvec3 p = b_T_a.transformPoint(a.depthIntrinsics.backProject(u, v, z));
            if (p.z <= 0.0) continue;
            const glm::dvec2 pixel = b.depthIntrinsics.project(p);
            const int ub = int(std::lround(pixel.x)), vb = int(std::lround(pixel.y));
            if (ub < 0 || vb < 0 || ub >= b.depth.cols || vb >= b.depth.rows) continue;
            const double zb = b.depthMetresAt(ub, vb);
            if (zb > 0.0) residuals.push_back(std::abs(p.z - zb));
        }
    return median(residuals);
}

TEST(RecordedDataTest, IclNuimGroundTruthPosesAlignTheDepthMaps) {
    auto source = capture::openFrameSource(dataPath("icl-nuim-open3d").string());
    ASSERT_EQ(source->frameCount(), 5);
    EXPECT_TRUE(source->info().hasGroundTruth);
    EXPECT_DOUBLE_EQ(source->info().depthScaleMetres, 0.001);
    std::vector<RgbdFrame> frames;
    RgbdFrame frame;
    while (source->next(frame)) {
        ASSERT_TRUE(frame.groundTruth_world_T_camera.has_value());
        frames.push_back(frame.clone());
    }
    ASSERT_EQ(frames.size(), 5u);
    // The camera moves ~10 cm between frame 0 and 4. Augmented ICL-NUIM depth carries simulated
    // Kinect noise: with the true poses the median residual is a flat ~5 mm for frame pairs 0-1
    // up to 0-4 (the noise floor), while assuming no motion grows to 40 mm at 0-4.
    const double aligned = reprojectionResidual(frames[0], frames[4], *frames[0].groundTruth_world_T_camera,
                                                *frames[4].groundTruth_world_T_camera);
    const double unaligned = reprojectionResidual(frames[0], frames[4], Pose(), Pose());
    std::printf("median residual: true poses %.4f m, identity %.4f m\n", aligned, unaligned);
    EXPECT_LT(aligned, 0.008);
    EXPECT_GT(unaligned, 4.0 * aligned);
    // The inverse convention (world_T_camera read as camera_T_world) must not align.
    const double inverted = reprojectionResidual(frames[0], frames[4], frames[0].groundTruth_world_T_camera->inverse(),
                                                 frames[4].groundTruth_world_T_camera->inverse());
    std::printf("inverted poses %.4f m\n", inverted);
    EXPECT_GT(inverted, 4.0 * aligned);
}

TEST(RecordedDataTest, PclKinectTiffFrameReadsWithItsDocumentedDepthRange) {
    const auto folder = dataPath("pcl-kinect-tiff");
    auto source = capture::openFrameSource(folder.string());
    ASSERT_EQ(source->frameCount(), 1);
    RgbdFrame frame;
    ASSERT_TRUE(source->next(frame));
    EXPECT_TRUE(identical(frame.colour,
                          cv::imread((folder / "frame_20121214T142255.814212_rgb.tiff").string(), cv::IMREAD_COLOR)));
    double minimum = 1e9, maximum = 0.0;
    for (int v = 0; v < frame.depth.rows; ++v)
        for (int u = 0; u < frame.depth.cols; ++u)
            if (const double z = frame.depthMetresAt(u, v); z > 0.0) {
                minimum = std::min(minimum, z);
                maximum = std::max(maximum, z);
            }
    // ../shared/data/README.md: "depth uint16 mm, 0.67-1.71 m" over the three frames.
    EXPECT_GE(minimum, 0.66);
    EXPECT_LE(maximum, 1.72);
    EXPECT_GT(maximum - minimum, 0.5);
    EXPECT_DOUBLE_EQ(frame.colourIntrinsics.cx, 320.0);
}

} // namespace
} // namespace lightskin::test
