#include "WallRecording.h"

#include <lightskin/capture/Recording.h>

#include <glm/gtc/quaternion.hpp>

namespace lightskin::test {

std::filesystem::path writeWallRecording(const std::filesystem::path& folder, const WallColour& colour,
                                         const std::string& deviceName) {
    capture::RecordingInfo info;
    info.deviceName = deviceName;
    info.colourIntrinsics = {kWallWidth, kWallHeight, 60.0, 60.0, 31.5, 23.5, {}};
    info.depthIntrinsics = info.colourIntrinsics;
    info.depthScaleMetres = 0.001;
    auto writer = capture::RecordingWriter::create(folder, info);
    for (int i = 0; i < kWallFrames; ++i) {
        RgbdFrame frame;
        frame.colourIntrinsics = frame.depthIntrinsics = info.colourIntrinsics;
        frame.depth = cv::Mat(kWallHeight, kWallWidth, CV_16UC1, cv::Scalar(1500));
        frame.depth.colRange(0, kWallWidth / 3).setTo(800);
        frame.colour.create(kWallHeight, kWallWidth, CV_8UC3);
        for (int v = 0; v < kWallHeight; ++v)
            for (int u = 0; u < kWallWidth; ++u) frame.colour.at<cv::Vec3b>(v, u) = colour(u, v);
        frame.colourTimestampSeconds = frame.depthTimestampSeconds = i / 30.0;
        // Camera 1 m in front of the world origin looking at it: world z towards the camera.
        frame.groundTruth_world_T_camera =
            Pose(glm::angleAxis(glm::pi<double>(), glm::dvec3(1, 0, 0)), {0.01 * i, 0.0, 1.0});
        writer.write(frame);
    }
    writer.finish();
    return folder;
}

} // namespace lightskin::test
