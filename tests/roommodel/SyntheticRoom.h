#pragma once
// A synthetic room for the room memory's tests: the inside of an axis-aligned box (walls, floor, ceiling) with one
// solid box (a table) in it, its depth rendered analytically (exact, noise-free; metres along z, CV_32FC1).

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>

#include <opencv2/core/mat.hpp>

namespace lightskin::test {

struct SyntheticRoom {
    glm::dvec3 roomMin{0.0, 0.0, 0.0}, roomMax{4.0, 3.5, 2.6};
    glm::dvec3 tableMin{1.4, 1.35, 0.0}, tableMax{2.6, 2.15, 0.75};
};

/// 320x240, f = 262.5 px (synth-orbit's Kinect v1 preset at half size).
CameraIntrinsics syntheticRoomIntrinsics();

/// Depth of the room seen from world_T_camera: z of the first surface along each pixel's ray (0 if none).
cv::Mat renderRoomDepth(const SyntheticRoom& room, const CameraIntrinsics& intrinsics, const Pose& world_T_camera);

/// A camera at `position` looking at `target`, world z up (the camera's y axis points down in the image).
Pose lookAt(const glm::dvec3& position, const glm::dvec3& target);

} // namespace lightskin::test

namespace lightskin::test {

/// Adds the Kinect v1 axial noise (FACTS.md: Nguyen, Izadi, Lovell 2012, sigma_z = 0.0012 + 0.0019 (z - 0.4)^2 m)
/// to every valid pixel of `depth`, reproducibly from `seed`.
void addKinectNoise(cv::Mat& depth, unsigned seed);

} // namespace lightskin::test
