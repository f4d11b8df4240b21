// lightskin_bench_roommodel_open3d: Open3D 0.16 (libopen3d-dev) on the frames lightskin_bench_roommodel uses, for
// the choice of the room memory's library (docs/ROOMMODEL.md "Candidates"). A separate program, never a test;
// built only when CMake finds Open3D. The same arguments as lightskin_bench_roommodel:
//   build/bench/lightskin_bench_roommodel_open3d [recording] [scene] [lostFrom] [lostTo]
// Printed: Open3D's TSDF fusion (ScalableTSDFVolume, the scene's voxel and truncation, colour RGB8) of the frames
// outside [lostFrom, lostTo) at their ground-truth poses, CPU ms per frame; and its RGB-D odometry (hybrid
// photometric and geometric term, Steinbruecker et al. 2011 / Park et al. 2017) frame to frame through the gap,
// chained from the last frame before it, against the ground truth.
#include "RoomModelBenchSupport.h"

#include <lightskin/core/CpuTime.h>
#include <lightskin/core/Error.h>
#include <lightskin/roommodel/RoomMemory.h>

#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <open3d/camera/PinholeCameraIntrinsic.h>
#include <open3d/geometry/Image.h>
#include <open3d/geometry/RGBDImage.h>
#include <open3d/pipelines/integration/ScalableTSDFVolume.h>
#include <open3d/pipelines/odometry/Odometry.h>
#include <string>
#include <vector>

namespace {

using namespace lightskin;
namespace o3d = open3d;

Eigen::Matrix4d toEigen(const Pose& pose) {
    const glm::dmat4 m = pose.matrix();
    Eigen::Matrix4d out;
    for (int row = 0; row < 4; ++row)
        for (int col = 0; col < 4; ++col) out(row, col) = m[col][row];
    return out;
}

Pose fromEigen(const Eigen::Matrix4d& m) {
    glm::dmat4 out(1.0);
    for (int row = 0; row < 4; ++row)
        for (int col = 0; col < 4; ++col) out[col][row] = m(row, col);
    return Pose::fromMatrix(out);
}

/// The frame as Open3D's RGBD image: colour (BGR in, RGB out) and depth (CV_32FC1 metres).
std::shared_ptr<o3d::geometry::RGBDImage> toOpen3d(const cv::Mat& colourBgr, const cv::Mat& depthMetres,
                                                   bool intensity) {
    o3d::geometry::Image colour, depth;
    colour.Prepare(colourBgr.cols, colourBgr.rows, 3, 1);
    for (int y = 0; y < colourBgr.rows; ++y)
        for (int x = 0; x < colourBgr.cols; ++x) {
            const cv::Vec3b bgr = colourBgr.at<cv::Vec3b>(y, x);
            std::uint8_t* rgb = colour.PointerAt<std::uint8_t>(x, y, 0);
            rgb[0] = bgr[2];
            rgb[1] = bgr[1];
            rgb[2] = bgr[0];
        }
    depth.Prepare(depthMetres.cols, depthMetres.rows, 1, 4);
    for (int y = 0; y < depthMetres.rows; ++y)
        std::memcpy(depth.PointerAt<float>(0, y), depthMetres.ptr<float>(y), std::size_t(depthMetres.cols) * 4);
    return o3d::geometry::RGBDImage::CreateFromColorAndDepth(colour, depth, 1.0, 4.0, intensity);
}

} // namespace

int main(int argc, char** argv) try {
    const bench::RoomModelBenchArguments args = bench::roomModelBenchArguments(argc, argv);
    const std::string &path = args.recording, &scene = args.scene;
    const int lostFrom = args.lostFrom, lostTo = args.lostTo;
    std::vector<RgbdFrame> frames;
    std::vector<cv::Mat> depths;
    bench::readFramesWithGroundTruth(path, frames, depths);
    roommodel::RoomModelSettings model; // defaults (4 cm) unless the scene says
    if (scene != "-")
        model = roommodel::roomMemorySettingsFromJson(bench::roomModelBlock(scene), scene, "/roomModel").model;
    const CameraIntrinsics& k = frames[0].depthIntrinsics;
    const o3d::camera::PinholeCameraIntrinsic intrinsic(k.width, k.height, k.fx, k.fy, k.cx, k.cy);
    o3d::pipelines::integration::ScalableTSDFVolume volume(model.voxelSizeMetres, model.truncationMetres,
                                                           o3d::pipelines::integration::TSDFVolumeColorType::RGB8);
    bench::FrameStats fuseCpuMs, odometryCpuMs, odometryWallMs, metres, degrees;
    Pose odometryPose;
    const o3d::pipelines::odometry::OdometryOption option({20, 10, 5}, 0.07, 0.0, model.maxDepthMetres);
    int tracked = 0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const Pose& truth = *frames[i].groundTruth_world_T_camera;
        const bool lost = int(i) >= lostFrom && int(i) < lostTo;
        if (!lost) {
            const auto rgbd = toOpen3d(frames[i].colour, depths[i], false);
            const double start = processCpuMs();
            volume.Integrate(*rgbd, intrinsic, toEigen(truth.inverse())); // extrinsic: camera_T_world
            fuseCpuMs.values.push_back(processCpuMs() - start);
            odometryPose = truth;
            continue;
        }
        const auto current = toOpen3d(frames[i].colour, depths[i], true);
        const auto previous = toOpen3d(frames[i - 1].colour, depths[i - 1], true);
        const double start = processCpuMs();
        const auto wallStart = std::chrono::steady_clock::now();
        const auto [ok, previous_T_current, information] = o3d::pipelines::odometry::ComputeRGBDOdometry(
            *current, *previous, intrinsic, Eigen::Matrix4d::Identity(),
            o3d::pipelines::odometry::RGBDOdometryJacobianFromHybridTerm(), option);
        odometryCpuMs.values.push_back(processCpuMs() - start);
        odometryWallMs.values.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wallStart).count());
        if (!ok) {
            std::printf("  frame %zu: Open3D odometry failed\n", i);
            continue;
        }
        ++tracked;
        odometryPose = odometryPose * fromEigen(previous_T_current);
        metres.values.push_back(Pose::translationDistance(odometryPose, truth));
        degrees.values.push_back(glm::degrees(Pose::rotationAngleBetween(odometryPose, truth)));
        std::printf("  frame %zu error %.4f m %.2f deg\n", i, metres.values.back(), degrees.values.back());
    }
    std::printf("%s, lost %d-%d, voxel %.3f m\n", path.c_str(), lostFrom, lostTo - 1, model.voxelSizeMetres);
    std::printf(
        "| Open3D ScalableTSDFVolume fusion CPU ms median / max | RGB-D odometry CPU / wall ms median | tracked | "
        "m mean / max | deg mean / max |\n");
    std::printf("| %.2f / %.2f | %.2f / %.2f | %d of %d | %.4f / %.4f | %.2f / %.2f |\n", fuseCpuMs.median(),
                fuseCpuMs.max(), odometryCpuMs.median(), odometryWallMs.median(), tracked, lostTo - lostFrom,
                metres.mean(), metres.max(), degrees.mean(), degrees.max());
    return 0;
} catch (const std::exception& error) {
    std::fprintf(stderr, "lightskin_bench_roommodel_open3d: %s\n", error.what());
    return 1;
}
