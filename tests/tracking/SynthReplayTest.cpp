// Tracking through the project's synthetic recordings (recordings/synth-*, rendered by
// lightskin synth with ground-truth camera poses and the scene's tag world): 320x240 frames with
// 15-40 px tags, Kinect-style depth noise and camera shake.
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/tracking/PoseTracker.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>

namespace lightskin::tracking {
namespace {

double degrees(double radians) { return radians * 180.0 / std::numbers::pi; }

std::string recording(const std::string& name) { return (test::sourceDir() / "recordings" / name).string(); }

TrackerSettings smallTagSettings() {
    TrackerSettings settings;
    settings.detector.quadDecimate = 1.0f; // 15-40 px tags
    return settings;
}

// synth-pan: the camera pans away from the table's tag board (no tag in view in frames 13-27)
// and back. States must be tracking -> held (10 frames) -> lost (no pose) -> tracking, and the
// unfiltered measurements must be accurate for such small tags.
TEST(SynthReplayTest, PanAwayAndBackStatesAndAccuracy) {
    const std::string folder = recording("synth-pan");
    const TagWorld world = TagWorld::load(folder + "/synth/tag-world.json");
    TrackerSettings settings = smallTagSettings();
    settings.maxHeldFrames = 10;
    PoseTracker tracker = PoseTracker::create(world, settings);
    auto source = capture::openFrameSource(folder);
    RgbdFrame frame;
    TrackingResult result;
    double worstRotation = 0.0, worstPosition = 0.0;
    while (source->next(frame)) {
        ASSERT_TRUE(frame.groundTruth_world_T_camera.has_value());
        tracker.trackInto(frame, result);
        const std::int64_t i = frame.index;
        const TrackingState expected = i <= 12 || i >= 28 ? TrackingState::Tracking
                                       : i <= 22          ? TrackingState::Held
                                                          : TrackingState::Lost;
        EXPECT_EQ(result.state, expected) << "frame " << i << ": " << result.reason;
        EXPECT_EQ(result.world_T_camera.has_value(), result.state != TrackingState::Lost) << "frame " << i;
        if (result.state != TrackingState::Tracking) continue;
        const Pose& measured = *result.measured_world_T_camera;
        worstRotation =
            std::max(worstRotation, degrees(Pose::rotationAngleBetween(measured, *frame.groundTruth_world_T_camera)));
        worstPosition = std::max(worstPosition, Pose::translationDistance(measured, *frame.groundTruth_world_T_camera));
        EXPECT_FALSE(result.ambiguous) << "frame " << i; // 2-4 board tags: a bundle view
    }
    std::printf("synth-pan: worst measured rotation error %.2f deg, camera position error %.1f mm\n", worstRotation,
                worstPosition * 1000.0);
    EXPECT_LE(worstRotation, 1.0);   // measured 0.74
    EXPECT_LE(worstPosition, 0.030); // measured 22 mm at ~1.5 m with 15-30 px tags
}

// synth-orbit: an orbit around the table at ~2.5-3.5 m; the table's 2x2 board (15 cm tags) is seen
// at a grazing angle (~24 x 10 px per tag), the 20 cm wall tag nearly head-on at ~17-21 px. At
// native size the library decodes a board tag in only 12 of the 40 frames, so most frames were the
// wall tag alone, whose orientation 17-21 px barely determine (rotation std 0.9-6 degrees; errors
// up to 12 degrees / 0.71 m). With the scene's detector settings (quadDecimate 1, upsample 2) board
// tags are found in 34 frames; the 6 frames left with the wall tag alone (14, 16-18, 22, 24) place
// the board's corners with a std of 11-26 px and are refused (maxWorldCornerStdPx): Held, not a
// wrong Tracking pose. Measured (unfiltered): tracked frames <= 0.067 m, <= 0.90 degrees.
TEST(SynthReplayTest, OrbitTracksWithBoardTagsAndHoldsWhenOnlyTheFarWallTagIsSeen) {
    const std::string folder = recording("synth-orbit");
    const TagWorld world = TagWorld::load(folder + "/synth/tag-world.json");
    TrackerSettings settings = smallTagSettings();
    settings.detector.upsample = 2;  // as recordings/scenes/orbit.json
    settings.filter.enabled = false; // judge the measurements themselves
    PoseTracker tracker = PoseTracker::create(world, settings);
    auto source = capture::openFrameSource(folder);
    RgbdFrame frame;
    TrackingResult result;
    int tracked = 0, held = 0;
    double worstRotation = 0.0, worstPosition = 0.0, worstHeldWallStd = std::numeric_limits<double>::infinity();
    while (source->next(frame)) {
        tracker.trackInto(frame, result);
        const Pose& truth = *frame.groundTruth_world_T_camera;
        if (result.state == TrackingState::Tracking) {
            ++tracked;
            const double rotation = degrees(Pose::rotationAngleBetween(*result.world_T_camera, truth));
            const double position = Pose::translationDistance(*result.world_T_camera, truth);
            worstRotation = std::max(worstRotation, rotation);
            worstPosition = std::max(worstPosition, position);
            EXPECT_LE(rotation, 1.5) << "frame " << frame.index;
            EXPECT_LE(position, 0.10) << "frame " << frame.index;
            EXPECT_LE(result.uncertainty.worldCornerStdPx, settings.maxWorldCornerStdPx);
        } else {
            ++held;
            // Never lost here (a few frames at a time), and refused for the stated reason only.
            EXPECT_EQ(result.state, TrackingState::Held) << "frame " << frame.index;
            EXPECT_NE(std::string(result.reason).find("poorly determined"), std::string::npos)
                << "frame " << frame.index << ": " << result.reason;
            EXPECT_GT(result.uncertainty.worldCornerStdPx, settings.maxWorldCornerStdPx);
            worstHeldWallStd = std::min(worstHeldWallStd, result.uncertainty.worldCornerStdPx);
        }
    }
    std::printf("synth-orbit: %d tracked (worst %.3f m, %.2f deg), %d held (smallest world-corner std %.1f px)\n",
                tracked, worstPosition, worstRotation, held, worstHeldWallStd);
    EXPECT_EQ(tracked + held, 40);
    EXPECT_GE(tracked, 32); // measured 34
}

// Without the upsampling the board is decoded in 12 frames: the tracker must still never report
// the far wall tag's badly determined poses as Tracking. Measured: 18 frames tracked (the 12 with
// board tags and 6 wall-tag-only frames whose world-corner std is 4.0-4.6 px), worst 0.066 m,
// 1.13 degrees; unchecked, the wall-tag-only frames were up to 0.71 m / 12.2 degrees off.
TEST(SynthReplayTest, OrbitAtNativeSizeIsHonestAboutTheFarWallTag) {
    const std::string folder = recording("synth-orbit");
    const TagWorld world = TagWorld::load(folder + "/synth/tag-world.json");
    TrackerSettings settings = smallTagSettings();
    settings.filter.enabled = false;
    PoseTracker tracker = PoseTracker::create(world, settings);
    auto source = capture::openFrameSource(folder);
    RgbdFrame frame;
    TrackingResult result;
    int tracked = 0;
    double worstRotation = 0.0, worstPosition = 0.0;
    while (source->next(frame)) {
        tracker.trackInto(frame, result);
        if (result.state != TrackingState::Tracking) continue;
        ++tracked;
        const Pose& truth = *frame.groundTruth_world_T_camera;
        worstRotation = std::max(worstRotation, degrees(Pose::rotationAngleBetween(*result.world_T_camera, truth)));
        worstPosition = std::max(worstPosition, Pose::translationDistance(*result.world_T_camera, truth));
        EXPECT_LE(Pose::translationDistance(*result.world_T_camera, truth), 0.10) << "frame " << frame.index;
    }
    std::printf("synth-orbit at native size: %d tracked (worst %.3f m, %.2f deg)\n", tracked, worstPosition,
                worstRotation);
    EXPECT_GE(tracked, 1);
    EXPECT_LE(worstRotation, 1.5);
}

} // namespace
} // namespace lightskin::tracking
