// lightskin_bench_roommodel: cost and accuracy of the room memory (roommodel/) on a recording with ground truth.
// A separate program, never a test; the numbers go to docs/BENCHMARKS.md "Room memory" with this command:
//   build/bench/lightskin_bench_roommodel [recording=recordings/synth-orbit] [scene=recordings/scenes/orbit.json]
//                                         [lostFrom=10] [lostTo=30] [voxelSizeMetres]
// The settings are the scene's "roomModel" block (scene "-": defaults, bounds 3 m around the camera path, up the
// world axis nearest the cameras' image-up); a
// voxel size given overrides the block's (and its truncation, kept at 3 voxels).
// Frames outside [lostFrom, lostTo) play tag-tracked frames (their ground-truth pose, fused); frames inside play
// frames whose tags are lost (Held), which the room memory tracks by ICP against the model. Printed: the fusion
// and the depth-tracking wall time per frame (ms, median and max: OpenCV's loops run on every core), the error of
// the depth-tracked poses against the ground truth, and beside it OpenCV's own frame-to-frame ICP odometry
// (cv::rgbd::ICPOdometry, the same depth, chained from the last tag-tracked frame).
#include "RoomModelBenchSupport.h"

#include <lightskin/core/CpuTime.h>
#include <lightskin/core/Error.h>
#include <lightskin/roommodel/RoomMemory.h>

#include <nlohmann/json.hpp>
#include <opencv2/rgbd/depth.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <string>
#include <vector>

namespace {

using namespace lightskin;

/// The box of the world around the ground-truth camera positions, +- `margin` metres.
void boundsAround(const std::vector<RgbdFrame>& frames, double margin, roommodel::RoomModelSettings& s) {
    glm::dvec3 lo(1e9), hi(-1e9);
    for (const RgbdFrame& f : frames) {
        lo = glm::min(lo, f.groundTruth_world_T_camera->translation());
        hi = glm::max(hi, f.groundTruth_world_T_camera->translation());
    }
    s.boundsMin = lo - margin;
    s.boundsMax = hi + margin;
    // Up: the world axis closest to the cameras' mean image-up (-y), signed.
    glm::dvec3 up(0.0);
    for (const RgbdFrame& f : frames) up -= f.groundTruth_world_T_camera->transformDirection({0.0, 1.0, 0.0});
    const glm::dvec3 a = glm::abs(up);
    const int axis = a.x > a.y && a.x > a.z ? 0 : a.y > a.z ? 1 : 2;
    s.up = glm::dvec3(0.0);
    s.up[axis] = up[axis] > 0.0 ? 1.0 : -1.0;
}

// CPU time of every thread of the process (OpenCV's loops run on its worker threads): on a shared machine the
// wall time counts the other processes' turns, this does not.
Pose poseFromCv(const cv::Mat& rt) {
    glm::dmat4 m(1.0);
    for (int row = 0; row < 4; ++row)
        for (int col = 0; col < 4; ++col) m[col][row] = rt.at<double>(row, col);
    return Pose::fromMatrix(m);
}

} // namespace

int main(int argc, char** argv) try {
    const bench::RoomModelBenchArguments args = bench::roomModelBenchArguments(argc, argv);
    const std::string &path = args.recording, &scene = args.scene;
    const int lostFrom = args.lostFrom, lostTo = args.lostTo;
    std::vector<RgbdFrame> frames;
    std::vector<cv::Mat> depths;
    bench::readFramesWithGroundTruth(path, frames, depths);
    roommodel::RoomMemorySettings settings;
    if (scene == "-") {
        settings.model.memoryBudgetMB = 1024.0;
        boundsAround(frames, 3.0, settings.model);
    } else {
        settings = roommodel::roomMemorySettingsFromJson(bench::roomModelBlock(scene), scene, "/roomModel");
    }
    if (argc > 5) {
        settings.model.voxelSizeMetres = std::atof(argv[5]);
        settings.model.truncationMetres = 3.0 * settings.model.voxelSizeMetres;
        settings.model.memoryBudgetMB = 4096.0;
    }
    settings.depthTracking.maxFrames = 1000;
    const double voxel = settings.model.voxelSizeMetres;
    auto memory = roommodel::RoomMemory::create(settings);
    const glm::ivec3 r = memory.model().resolution();
    std::printf("%s: %zu frames %dx%d, lost %d-%d, voxel %.3f m, up [%g %g %g], %dx%dx%d voxels = %.1f MB\n",
                path.c_str(), frames.size(), frames[0].depth.cols, frames[0].depth.rows, lostFrom, lostTo - 1, voxel,
                settings.model.up.x, settings.model.up.y, settings.model.up.z, r.x, r.y, r.z,
                double(memory.model().voxelBytes()) * 1e-6);

    bench::FrameStats fuseMs, trackMs, renderMs, fuseCpuMs, trackCpuMs, metres, degrees, odoMetres, odoDegrees;
    const CameraIntrinsics& k = frames[0].depthIntrinsics;
    const cv::Mat cameraMatrix =
        (cv::Mat_<float>(3, 3) << float(k.fx), 0.f, float(k.cx), 0.f, float(k.fy), float(k.cy), 0.f, 0.f, 1.f);
    auto odometry = cv::rgbd::ICPOdometry::create(cameraMatrix, 0.3f, 4.0f);
    Pose odometryPose;
    cv::Mat rt;
    int depthTracked = 0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const Pose& truth = *frames[i].groundTruth_world_T_camera;
        const bool lost = int(i) >= lostFrom && int(i) < lostTo;
        tracking::TrackingResult result;
        result.state = lost ? tracking::TrackingState::Held : tracking::TrackingState::Tracking;
        result.world_T_camera = truth; // Held: overwritten by the room memory, or the (wrong) truth stays unscored
        const double cpuStart = processCpuMs();
        memory.update(depths[i], k, result);
        (lost ? trackCpuMs : fuseCpuMs).values.push_back(processCpuMs() - cpuStart);
        const roommodel::RoomMemoryStats& t = memory.lastStats();
        if (t.fuseMs >= 0.0) fuseMs.values.push_back(t.fuseMs);
        if (t.trackMs >= 0.0) trackMs.values.push_back(t.trackMs);
        if (t.renderMs >= 0.0) renderMs.values.push_back(t.renderMs);
        if (lost)
            std::printf("  frame %zu %s constraint ratio %.5f error %.4f m %.2f deg\n", i,
                        tracking::toString(result.state), t.constraintRatio,
                        result.world_T_camera ? Pose::translationDistance(*result.world_T_camera, truth) : -1.0,
                        result.world_T_camera ? glm::degrees(Pose::rotationAngleBetween(*result.world_T_camera, truth))
                                              : -1.0);
        if (lost && result.state == tracking::TrackingState::DepthTracked) {
            ++depthTracked;
            metres.values.push_back(Pose::translationDistance(*result.world_T_camera, truth));
            degrees.values.push_back(glm::degrees(Pose::rotationAngleBetween(*result.world_T_camera, truth)));
        }
        if (!lost) {
            odometryPose = truth;
        } else if (odometry->compute(cv::Mat(), depths[i], cv::Mat(), cv::Mat(), depths[i - 1], cv::Mat(), rt)) {
            odometryPose = odometryPose * poseFromCv(rt); // Rt: previous_T_current (dst_p = Rt * src_p)
            odoMetres.values.push_back(Pose::translationDistance(odometryPose, truth));
            odoDegrees.values.push_back(glm::degrees(Pose::rotationAngleBetween(odometryPose, truth)));
        }
    }
    std::printf("CPU ms per frame, median, all threads: tag frame (fusion) %.2f, frame without tags (depth tracking) "
                "%.2f\n",
                fuseCpuMs.median(), trackCpuMs.median());
    std::printf("| fusion ms median / max | depth tracking ms median / max (render median) | depth-tracked frames | "
                "room memory error "
                "m mean / max | deg mean / max | OpenCV ICPOdometry frame-to-frame m mean / max | deg mean / max |\n");
    std::printf(
        "| %.2f / %.2f | %.2f / %.2f (%.2f) | %d of %d | %.4f / %.4f | %.2f / %.2f | %.4f / %.4f | %.2f / %.2f |\n",
        fuseMs.median(), fuseMs.max(), trackMs.median(), trackMs.max(), renderMs.median(), depthTracked,
        lostTo - lostFrom, metres.mean(), metres.max(), degrees.mean(), degrees.max(), odoMetres.mean(),
        odoMetres.max(), odoDegrees.mean(), odoDegrees.max());
    return 0;
} catch (const std::exception& error) {
    std::fprintf(stderr, "lightskin_bench_roommodel: %s\n", error.what());
    return 1;
}
