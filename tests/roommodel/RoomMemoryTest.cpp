#include "SyntheticRoom.h"

#include <lightskin/core/Error.h>
#include <lightskin/roommodel/RoomMemory.h>

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace lightskin::roommodel {
namespace {

using test::lookAt;
using test::renderRoomDepth;
using test::SyntheticRoom;
using test::syntheticRoomIntrinsics;
using tracking::TrackingResult;
using tracking::TrackingState;

/// Frame i of an orbit around the table as synth-orbit's: radius 1.6 m, 1.5 m high, 3 degrees per frame (8 cm of
/// travel per frame at 30 fps).
Pose orbitPose(int i) {
    const double angle = glm::radians(210.0 + 3.0 * i);
    const glm::dvec3 centre(2.0, 1.75, 0.0);
    return lookAt(centre + glm::dvec3(1.6 * std::cos(angle), 1.6 * std::sin(angle), 1.5), {2.0, 2.0, 0.8});
}

/// 2 cm voxels, 6 cm truncation: the bounds below are derived for these.
RoomMemorySettings roomSettings(const SyntheticRoom& room) {
    RoomMemorySettings s;
    s.model.voxelSizeMetres = 0.02;
    s.model.truncationMetres = 0.06;
    s.model.boundsMin = room.roomMin - 0.1;
    s.model.boundsMax = room.roomMax + 0.1;
    return s;
}

/// The tag tracker's result as PoseTracker gives it: Held frames carry the last tag pose.
TrackingResult tagResult(TrackingState state, const Pose& pose) {
    TrackingResult r;
    r.state = state;
    r.world_T_camera = pose;
    return r;
}

struct Frame {
    TrackingState state;
    Pose pose;
};

/// Runs frames 0..count-1 of the orbit; frames in [lostFrom, lostTo) have no tags (Held at the last tag pose).
/// `tagBias` is added to the tag poses from lostTo on (a tag pose that disagrees with the depth pose).
std::vector<Frame> runOrbit(RoomMemory& memory, int count, int lostFrom, int lostTo, bool noise,
                            const Pose& tagBias = Pose()) {
    const SyntheticRoom room;
    const CameraIntrinsics k = syntheticRoomIntrinsics();
    std::vector<Frame> out;
    for (int i = 0; i < count; ++i) {
        const bool lost = i >= lostFrom && i < lostTo;
        cv::Mat depth = renderRoomDepth(room, k, orbitPose(i));
        if (noise) test::addKinectNoise(depth, unsigned(i));
        const Pose tag = i >= lostTo ? orbitPose(i) * tagBias : orbitPose(i);
        TrackingResult r =
            tagResult(lost ? TrackingState::Held : TrackingState::Tracking, lost ? orbitPose(lostFrom - 1) : tag);
        memory.update(depth, k, r);
        out.push_back({r.state, r.world_T_camera.value_or(Pose())});
    }
    return out;
}

TEST(RoomMemory, TracksFramesWithoutTagsWithinTheNoiseBound) {
    // Kinect v1 noise: sigma_z = 0.0012 + 0.0019 (z - 0.4)^2 = 3.8 to 10 mm over this view's 1.6-2.6 m. Per frame,
    // ICP against the model (not the previous frame: no accumulation through the model) is off by about the
    // model's surface error: the fused noise sigma_z / sqrt(10 frames) = 3 mm plus the 8-bit distance quantum
    // 0.5 mm (0.06 m / 127), at 160x120. ICP from frame to frame chains these, so the error grows at most
    // linearly: 4 mm per frame over synth-orbit's longest tag gap (3 frames, here 6 for margin) gives 24 mm and
    // the tag-pose goal of 0.03 m. Rotation: 4 mm over the ~1 m lever of the view is 0.23 degree per frame;
    // linear over 6 frames 1.4, the goal of 1 degree taken (the ICP averages thousands of points).
    const SyntheticRoom room;
    auto memory = RoomMemory::create(roomSettings(room));
    const std::vector<Frame> frames = runOrbit(memory, 20, 10, 16, true);
    for (int i = 10; i < 16; ++i) {
        SCOPED_TRACE(i);
        EXPECT_EQ(frames[std::size_t(i)].state, TrackingState::DepthTracked);
        EXPECT_LT(Pose::translationDistance(frames[std::size_t(i)].pose, orbitPose(i)), 0.024);
        EXPECT_LT(glm::degrees(Pose::rotationAngleBetween(frames[std::size_t(i)].pose, orbitPose(i))), 1.0);
    }
    EXPECT_EQ(frames[16].state, TrackingState::Tracking);
    EXPECT_EQ(memory.model().integratedFrames(), 10 + 4); // depth-tracked frames are not fused
}

TEST(RoomMemory, ReturnsToTheTagsWithoutAJump) {
    // The tags come back 3 cm off the depth pose. Without the blend the output would jump 3 cm in one frame; with
    // it, the output's step differs from the true step by at most |D| / blendFrames = 3.75 mm plus the depth
    // pose's own error on the first tag frame (noise-free depth: under 2 mm, the TSDF quantum and the 160x120 ICP).
    const SyntheticRoom room;
    RoomMemorySettings s = roomSettings(room);
    s.depthTracking.blendFrames = 8;
    auto memory = RoomMemory::create(s);
    const Pose bias(glm::dquat(1.0, 0.0, 0.0, 0.0), glm::dvec3(0.03, 0.0, 0.0));
    const std::vector<Frame> frames = runOrbit(memory, 30, 10, 14, false, bias);
    const double bound = 0.03 / 8.0 + 0.002;
    for (int i = 11; i < 30; ++i) {
        SCOPED_TRACE(i);
        const Pose step = frames[std::size_t(i - 1)].pose.inverse() * frames[std::size_t(i)].pose;
        const Pose trueStep = orbitPose(i - 1).inverse() * orbitPose(i);
        EXPECT_LT(Pose::translationDistance(step, trueStep), bound);
    }
    EXPECT_EQ(frames[13].state, TrackingState::DepthTracked);
    EXPECT_EQ(frames[14].state, TrackingState::Tracking);
    // The first tag frame shows its depth pose (within the depth error), the ninth the tag pose exactly.
    EXPECT_LT(Pose::translationDistance(frames[14].pose, orbitPose(14)), 0.002);
    EXPECT_LT(Pose::translationDistance(frames[22].pose, orbitPose(22) * bias), 1e-9);
}

TEST(RoomMemory, LeavesHeldFramesAloneWithoutAModel) {
    auto memory = RoomMemory::create(roomSettings(SyntheticRoom()));
    const CameraIntrinsics k = syntheticRoomIntrinsics();
    TrackingResult r = tagResult(TrackingState::Held, orbitPose(0));
    memory.update(renderRoomDepth(SyntheticRoom(), k, orbitPose(1)), k, r);
    EXPECT_EQ(r.state, TrackingState::Held);
    EXPECT_LT(Pose::translationDistance(*r.world_T_camera, orbitPose(0)), 1e-12);
}

TEST(RoomMemory, DepthTrackingEndsAfterMaxFrames) {
    RoomMemorySettings s = roomSettings(SyntheticRoom());
    s.depthTracking.maxFrames = 3;
    auto memory = RoomMemory::create(s);
    const std::vector<Frame> frames = runOrbit(memory, 16, 10, 16, false);
    for (int i = 10; i < 13; ++i) EXPECT_EQ(frames[std::size_t(i)].state, TrackingState::DepthTracked) << i;
    for (int i = 13; i < 16; ++i) EXPECT_EQ(frames[std::size_t(i)].state, TrackingState::Lost) << i;
}

TEST(RoomMemory, RefusesAViewOfAFlatWallAndWaitsForTheTags) {
    // Facing the west wall from 0.8 m (the view spans +-0.48 m by +-0.37 m of it, nothing else): sliding along
    // the wall and turning about its normal leave the depth unchanged, so ICP cannot fix them. The constraint
    // ratio of three free motions is ~0 whatever the noise; the gate is 0.04.
    const SyntheticRoom room;
    auto memory = RoomMemory::create(roomSettings(room));
    const CameraIntrinsics k = syntheticRoomIntrinsics();
    const Pose wall = lookAt({0.8, 1.75, 1.3}, {0.0, 1.75, 1.29});
    TrackingResult tagged = tagResult(TrackingState::Tracking, wall);
    memory.update(renderRoomDepth(room, k, wall), k, tagged);
    const Pose moved = wall * Pose(glm::dquat(1.0, 0.0, 0.0, 0.0), glm::dvec3(0.01, 0.0, 0.0));
    TrackingResult held = tagResult(TrackingState::Held, wall);
    memory.update(renderRoomDepth(room, k, moved), k, held);
    EXPECT_EQ(held.state, TrackingState::Held);
    EXPECT_LT(memory.lastStats().constraintRatio, 0.04);
    EXPECT_GE(memory.lastStats().constraintRatio, 0.0);
    // The next frame without tags does not try again from the stale pose.
    held = tagResult(TrackingState::Held, wall);
    memory.update(renderRoomDepth(room, k, moved), k, held);
    EXPECT_EQ(held.state, TrackingState::Held);
    EXPECT_EQ(memory.lastStats().trackMs, -1.0);
}

TEST(RoomMemory, BadSettingsNameTheirKey) {
    RoomMemorySettings s;
    s.depthTracking.blendFrames = 0;
    try {
        RoomMemory::create(s);
        FAIL() << "no error";
    } catch (const Error& error) {
        EXPECT_EQ(error.cause().rfind("/depthTracking/blendFrames: ", 0), 0u) << error.cause();
    }
}

} // namespace
} // namespace lightskin::roommodel
