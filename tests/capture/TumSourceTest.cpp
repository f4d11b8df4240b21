// TUM layout reader on synthetic lists: association, ground-truth lookup, options.
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <fstream>

namespace lightskin::test {
namespace {

/// Writes a TUM folder with 4x3 images; depth pixel values encode the file's index.
std::filesystem::path makeTumFolder(const std::string& name, const std::vector<double>& rgbTimes,
                                    const std::vector<double>& depthTimes, const std::string& groundTruth = {}) {
    const auto folder = scratchDir(name);
    std::filesystem::create_directories(folder / "rgb");
    std::filesystem::create_directories(folder / "depth");
    std::ofstream rgb(folder / "rgb.txt"), depth(folder / "depth.txt");
    rgb << "# color images\n# file: test\n# timestamp filename\n";
    depth << "# depth maps\n# file: test\n# timestamp filename\n";
    rgb.precision(17);
    depth.precision(17);
    for (std::size_t i = 0; i < rgbTimes.size(); ++i) {
        const std::string file = "rgb/" + std::to_string(i) + ".png";
        cv::imwrite((folder / file).string(), cv::Mat(3, 4, CV_8UC3, cv::Scalar(double(i), 0, 0)));
        rgb << rgbTimes[i] << " " << file << "\n";
    }
    for (std::size_t i = 0; i < depthTimes.size(); ++i) {
        const std::string file = "depth/" + std::to_string(i) + ".png";
        cv::imwrite((folder / file).string(), cv::Mat(3, 4, CV_16UC1, cv::Scalar(5000.0 + double(i))));
        depth << depthTimes[i] << " " << file << "\n";
    }
    if (!groundTruth.empty()) std::ofstream(folder / "groundtruth.txt") << groundTruth;
    return folder;
}

capture::FrameSourceOptions smallCamera() {
    capture::FrameSourceOptions options;
    options.intrinsics = CameraIntrinsics{4, 3, 5.0, 5.0, 1.5, 1.0, {}};
    return options;
}

TEST(TumSourceTest, AssociatesNearestTimestampsWithinTheLimit) {
    const auto folder = makeTumFolder("tum_associate", {0.0, 0.033, 0.066, 0.1}, {0.004, 0.040, 0.061, 0.2});
    auto source = capture::openFrameSource(folder.string(), smallCamera());
    EXPECT_EQ(source->info().kind, "tum");
    ASSERT_EQ(source->frameCount(), 3); // 0.1 has no depth within 0.02 s
    RgbdFrame frame;
    const int expectedDepth[] = {0, 1, 2};
    for (int i = 0; i < 3; ++i) {
        ASSERT_TRUE(source->next(frame));
        EXPECT_EQ(frame.colour.at<cv::Vec3b>(0, 0)[0], i);
        EXPECT_EQ(frame.depth.at<std::uint16_t>(0, 0), 5000 + expectedDepth[i]);
        EXPECT_DOUBLE_EQ(frame.depthScaleMetres, 0.0002);
        EXPECT_DOUBLE_EQ(frame.depthMetresAt(0, 0), (5000.0 + expectedDepth[i]) / 5000.0);
        EXPECT_FALSE(frame.groundTruth_world_T_camera.has_value());
    }
    EXPECT_FALSE(source->next(frame));

    auto tight = smallCamera();
    tight.maxAssociationSeconds = 0.0045; // only 0.0 <-> 0.004 remains
    EXPECT_EQ(capture::openFrameSource(folder.string(), tight)->frameCount(), 1);
    tight.maxAssociationSeconds = 0.001;
    EXPECT_THROW(capture::openFrameSource(folder.string(), tight), Error);
}

TEST(TumSourceTest, EachImageIsUsedOnceClosestPairFirst) {
    // Depth 0.012 is 0.012 from colour 0.0 and 0.008 from colour 0.02: it goes to 0.02, and
    // colour 0.0 takes depth -0.01 (0.01 away) instead.
    const auto folder = makeTumFolder("tum_unique", {0.0, 0.02}, {-0.01, 0.012});
    auto source = capture::openFrameSource(folder.string(), smallCamera());
    ASSERT_EQ(source->frameCount(), 2);
    RgbdFrame frame;
    ASSERT_TRUE(source->next(frame));
    EXPECT_DOUBLE_EQ(frame.depthTimestampSeconds, -0.01);
    ASSERT_TRUE(source->next(frame));
    EXPECT_DOUBLE_EQ(frame.depthTimestampSeconds, 0.012);
    EXPECT_DOUBLE_EQ(frame.colourTimestampSeconds, 0.02);
}

TEST(TumSourceTest, GroundTruthIsInterpolatedAtTheColourTimestamp) {
    // Camera-to-world: translation moves 1 m along x per 0.04 s, rotation 90 degrees about z.
    const double s = std::sqrt(0.5);
    const std::string groundTruth =
        "# ground truth\n0.0 0 0 0 0 0 0 1\n0.04 1 0 0 0 0 " + std::to_string(s) + " " + std::to_string(s) + "\n";
    const auto folder = makeTumFolder("tum_groundtruth", {0.01, 0.5}, {0.01, 0.5}, groundTruth);
    auto source = capture::openFrameSource(folder.string(), smallCamera());
    EXPECT_TRUE(source->info().hasGroundTruth);
    RgbdFrame frame;
    ASSERT_TRUE(source->next(frame));
    ASSERT_TRUE(frame.groundTruth_world_T_camera.has_value());
    EXPECT_NEAR(frame.groundTruth_world_T_camera->translation().x, 0.25, 1e-9);
    EXPECT_NEAR(Pose::rotationAngleBetween(*frame.groundTruth_world_T_camera, Pose()), M_PI / 8.0, 1e-6);
    // The camera's x axis maps into the world rotated by 22.5 degrees about z.
    const glm::dvec3 x = frame.groundTruth_world_T_camera->transformDirection({1, 0, 0});
    EXPECT_NEAR(std::atan2(x.y, x.x), M_PI / 8.0, 1e-6);
    ASSERT_TRUE(source->next(frame));
    EXPECT_FALSE(frame.groundTruth_world_T_camera.has_value()) << "no ground truth near 0.5 s";
}

TEST(TumSourceTest, IntrinsicsComeFromOptionSidecarOrFolderName) {
    auto folder = makeTumFolder("tum_intrinsics", {0.0}, {0.0});
    std::ofstream(folder / "lightskin-camera.json")
        << R"({"colour": {"width": 4, "height": 3, "fx": 7, "fy": 8, "cx": 1.5, "cy": 1}, "depthScaleMetres": 0.001})";
    auto source = capture::openFrameSource(folder.string());
    EXPECT_DOUBLE_EQ(source->info().colourIntrinsics.fx, 7.0);
    EXPECT_DOUBLE_EQ(source->info().depthScaleMetres, 0.001);
    EXPECT_DOUBLE_EQ(capture::openFrameSource(folder.string(), smallCamera())->info().colourIntrinsics.fx, 5.0);

    // A folder named like a TUM sequence gets that camera's calibration (640x480 images here).
    const auto fr3 = scratchDir("rgbd_dataset_freiburg3_test");
    cv::imwrite((fr3 / "c.png").string(), cv::Mat(480, 640, CV_8UC3, cv::Scalar(1, 2, 3)));
    cv::imwrite((fr3 / "d.png").string(), cv::Mat(480, 640, CV_16UC1, cv::Scalar(1)));
    std::ofstream(fr3 / "rgb.txt") << "1.0 c.png\n";
    std::ofstream(fr3 / "depth.txt") << "1.0 d.png\n";
    auto fr3Source = capture::openFrameSource(fr3.string());
    EXPECT_DOUBLE_EQ(fr3Source->info().colourIntrinsics.fx, CameraIntrinsics::tumFreiburg3().fx);
    RgbdFrame frame;
    EXPECT_TRUE(fr3Source->next(frame));
}

} // namespace
} // namespace lightskin::test
