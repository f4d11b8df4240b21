// Tracking through the project's synthetic recordings (recordings/synth-*, rendered by
// lightskin synth with ground-truth camera poses and the scene's tag world): 320x240 frames with
// 15-40 px tags, Kinect-style depth noise and camera shake.
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/tracking/PoseTracker.h>
#include <lightskin/tracking/TagDetector.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

namespace lightskin::tracking {
namespace {

double degrees(double radians) { return radians * 180.0 / std::numbers::pi; }

std::string recording(const std::string& name) { return (test::sourceDir() / "recordings" / name).string(); }

// Pose-error budget (a requirement, docs/TESTING.md "Pose-error budget"): a tracked pose may displace
// the world's content in the image by at most 1.5 degrees of view angle at 2 sigma; the tracker's
// maxWorldCornerStdPx is derived from it. The tests assert 3 sigma of it (1.5x the budget), so that a
// correct tracker at its acceptance limit fails a frame with probability 0.3 %:
// - the world's content (every corner of every world tag in front of the camera) lands within
//   1.5 f tan(1.5 deg) px of where the true pose puts it (10.3 px at the recordings' f = 262.5);
// - rotation error <= 2.25 degrees (content at any distance moves by the camera's rotation error);
// - camera position error across the viewing direction <= 1.5 z tan(1.5 deg), z = the distance from
//   the true camera to the nearest world tag (the content stands by the tags; a sideways error d
//   moves it by d / z). Along the viewing direction an error only rescales the image about its
//   centre, which the budget (an angle) does not bound; it is printed, not asserted (finding: on
//   synth-orbit frame 25 the camera is 0.057 m off along the view at 2.5 m while the tags move by
//   < 1 px in the image).
constexpr double kBudgetDegrees = 1.5;
constexpr double kSigmasOverBudgetSigmas = 1.5; // 3 sigma asserted / 2 sigma budgeted
constexpr double kRotationBoundDegrees = kSigmasOverBudgetSigmas * kBudgetDegrees;
const double kBudgetTangent = std::tan(kBudgetDegrees * std::numbers::pi / 180.0);

double sidewaysBoundMetres(const TagWorld& world, const Pose& world_T_camera) {
    double nearest = std::numeric_limits<double>::infinity();
    for (const WorldTag& tag : world.tags())
        nearest = std::min(nearest, glm::length(tag.world_T_tag.translation() - world_T_camera.translation()));
    return kSigmasOverBudgetSigmas * nearest * kBudgetTangent;
}

/// Camera position error split into its parts along and across the true viewing direction, metres.
struct PositionError {
    double along = 0.0, across = 0.0;
};
PositionError positionError(const Pose& estimate, const Pose& truth) {
    const glm::dvec3 d = estimate.translation() - truth.translation();
    const glm::dvec3 view = truth.transformDirection(glm::dvec3(0.0, 0.0, 1.0));
    const double along = glm::dot(d, view);
    return {along, glm::length(d - along * view)};
}

/// Largest image displacement, pixels, of any world tag corner in front of the true camera between
/// the true and the estimated pose: how far the content moves in the picture.
double contentDisplacementPx(const TagWorld& world, const Pose& estimate, const Pose& truth,
                             const CameraIntrinsics& k) {
    const Pose trueCamera_T_world = truth.inverse(), camera_T_world = estimate.inverse();
    double worst = 0.0;
    for (const WorldTag& tag : world.tags()) {
        const double h = 0.5 * tag.sizeMetres;
        for (const glm::dvec3 corner :
             {glm::dvec3(-h, -h, 0), glm::dvec3(h, -h, 0), glm::dvec3(h, h, 0), glm::dvec3(-h, h, 0)}) {
            const glm::dvec3 w = tag.world_T_tag.transformPoint(corner);
            const glm::dvec3 a = trueCamera_T_world.transformPoint(w), b = camera_T_world.transformPoint(w);
            if (a.z > 0.0 && b.z > 0.0) worst = std::max(worst, glm::length(k.project(a) - k.project(b)));
        }
    }
    return worst;
}

/// All of the budget's bounds for one tracked frame (see above); prints nothing, records the worst.
struct BudgetCheck {
    double worstRotation = 0.0, worstAcross = 0.0, worstAlong = 0.0, worstDisplacementPx = 0.0;
    void check(const TagWorld& world, const Pose& estimate, const Pose& truth, const CameraIntrinsics& k,
               std::int64_t frame) {
        const double rotation = degrees(Pose::rotationAngleBetween(estimate, truth));
        const PositionError position = positionError(estimate, truth);
        const double displacement = contentDisplacementPx(world, estimate, truth, k);
        worstRotation = std::max(worstRotation, rotation);
        worstAcross = std::max(worstAcross, position.across);
        worstAlong = std::max(worstAlong, std::abs(position.along));
        worstDisplacementPx = std::max(worstDisplacementPx, displacement);
        EXPECT_LE(displacement, kSigmasOverBudgetSigmas * k.fx * kBudgetTangent) << "frame " << frame;
        EXPECT_LE(rotation, kRotationBoundDegrees) << "frame " << frame;
        EXPECT_LE(position.across, sidewaysBoundMetres(world, truth)) << "frame " << frame;
    }
    std::string describe() const {
        char text[200];
        std::snprintf(text, sizeof text,
                      "worst: content %.2f px, rotation %.2f deg, position %.3f m across / %.3f m along the view",
                      worstDisplacementPx, worstRotation, worstAcross, worstAlong);
        return text;
    }
};

/// Some world tag lies wholly in the image at the true pose: its four corners in front of the camera
/// and inside the image (from the ground truth and the tag world, not from any detector).
bool tagInView(const TagWorld& world, const Pose& world_T_camera, const CameraIntrinsics& k) {
    const Pose camera_T_world = world_T_camera.inverse();
    for (const WorldTag& tag : world.tags()) {
        bool inside = true;
        const double h = 0.5 * tag.sizeMetres;
        for (const glm::dvec3 corner :
             {glm::dvec3(-h, -h, 0), glm::dvec3(h, -h, 0), glm::dvec3(h, h, 0), glm::dvec3(-h, h, 0)}) {
            const glm::dvec3 c = camera_T_world.transformPoint(tag.world_T_tag.transformPoint(corner));
            const glm::dvec2 p = c.z > 0.0 ? k.project(c) : glm::dvec2(-1.0);
            inside = inside && c.z > 0.0 && p.x >= 0.0 && p.y >= 0.0 && p.x <= k.width - 1.0 && p.y <= k.height - 1.0;
        }
        if (inside) return true;
    }
    return false;
}

/// Whether the detector with `settings` decodes a tag of `world` other than `excludedId` in the frame.
bool decodesTagOtherThan(TagDetector& detector, const RgbdFrame& frame, int excludedId,
                         std::vector<TagDetection>& found) {
    detector.detectInto(frame.colour, found);
    return std::any_of(found.begin(), found.end(), [excludedId](const TagDetection& d) { return d.id != excludedId; });
}

TrackerSettings smallTagSettings() {
    TrackerSettings settings;
    settings.detector.quadDecimate = 1.0f; // 15-40 px tags
    return settings;
}

// synth-pan: the camera pans away from the table's tag board and back. Expected states from the
// ground truth and the settings alone: Tracking where a world tag lies wholly in the image, Held
// for the first maxHeldFrames frames without one, Lost (no pose) after that. (Measured: tags out of
// view in frames 13-27: tracking 0-12, held 13-22, lost 23-27, tracking 28-39.) Accuracy within
// the pose-error budget (above); measured worst 0.74 degrees, 22 mm at ~1.5 m.
TEST(SynthReplayTest, PanAwayAndBackStatesAndAccuracy) {
    const std::string folder = recording("synth-pan");
    const TagWorld world = TagWorld::load(folder + "/synth/tag-world.json");
    TrackerSettings settings = smallTagSettings();
    settings.maxHeldFrames = 10;
    PoseTracker tracker = PoseTracker::create(world, settings);
    auto source = capture::openFrameSource(folder);
    RgbdFrame frame;
    TrackingResult result;
    BudgetCheck budget;
    int framesWithoutTag = 0, tracked = 0, held = 0, lost = 0;
    while (source->next(frame)) {
        ASSERT_TRUE(frame.groundTruth_world_T_camera.has_value());
        const Pose& truth = *frame.groundTruth_world_T_camera;
        tracker.trackInto(frame, result);
        const std::int64_t i = frame.index;
        framesWithoutTag = tagInView(world, truth, frame.colourIntrinsics) ? 0 : framesWithoutTag + 1;
        const TrackingState expected = framesWithoutTag == 0                        ? TrackingState::Tracking
                                       : framesWithoutTag <= settings.maxHeldFrames ? TrackingState::Held
                                                                                    : TrackingState::Lost;
        EXPECT_EQ(result.state, expected) << "frame " << i << ": " << result.reason;
        EXPECT_EQ(result.world_T_camera.has_value(), result.state != TrackingState::Lost) << "frame " << i;
        tracked += result.state == TrackingState::Tracking;
        held += result.state == TrackingState::Held;
        lost += result.state == TrackingState::Lost;
        if (result.state != TrackingState::Tracking) continue;
        budget.check(world, *result.measured_world_T_camera, truth, frame.colourIntrinsics, i);
        EXPECT_FALSE(result.ambiguous) << "frame " << i; // 2-4 board tags: a bundle view
    }
    std::printf("synth-pan: %d tracking, %d held, %d lost; %s\n", tracked, held, lost, budget.describe().c_str());
    // The recording must exercise every state (else the per-frame expectations above prove little).
    EXPECT_GT(tracked, 0);
    EXPECT_GT(held, 0);
    EXPECT_GT(lost, 0);
}

// synth-orbit: an orbit around the table at ~2.5-3.5 m; the table's 2x2 board (15 cm tags) is seen
// at a grazing angle (~24 x 10 px per tag), the 20 cm wall tag (id 10) nearly head-on at ~17-21 px.
// The wall tag alone barely determines the orientation (rotation std 0.9-6 degrees; errors up to
// 12 degrees / 0.71 m when accepted); its poses place the board's corners with a std far above the
// budget's maxWorldCornerStdPx and are refused: Held, not a wrong Tracking pose. So the expected
// state follows from what the detector decodes (run separately with the same settings): Tracking
// exactly when a board tag is decoded, Held when only the wall tag is. With the scene's detector
// settings (quadDecimate 1, upsample 2) more frames decode a board tag than at native size.
// Measured: board decoded in 34 frames with upsample 2, 12 at native size; tracked frames
// (unfiltered) <= 0.067 m, <= 0.90 degrees; the 6 wall-only frames 11-26 px.
struct OrbitRun {
    int tracked = 0, boardFrames = 0;
};

OrbitRun runOrbit(int upsample) {
    const std::string folder = recording("synth-orbit");
    const TagWorld world = TagWorld::load(folder + "/synth/tag-world.json");
    constexpr int kWallTag = 10; // synth/tag-world.json: the 20 cm tag on the wall
    EXPECT_NE(world.find(kWallTag), nullptr);
    TrackerSettings settings = smallTagSettings();
    settings.detector.upsample = upsample; // 2 as recordings/scenes/orbit.json
    settings.filter.enabled = false;       // judge the measurements themselves
    PoseTracker tracker = PoseTracker::create(world, settings);
    DetectorSettings detectorSettings = settings.detector;
    detectorSettings.family = world.family();
    TagDetector detector = TagDetector::create(detectorSettings);
    auto source = capture::openFrameSource(folder);
    RgbdFrame frame;
    TrackingResult result;
    std::vector<TagDetection> found;
    OrbitRun run;
    int frames = 0, held = 0, lost = 0, framesWithoutMeasurement = 0;
    BudgetCheck budget;
    double smallestHeldStd = std::numeric_limits<double>::infinity();
    while (source->next(frame)) {
        ++frames;
        tracker.trackInto(frame, result);
        const Pose& truth = *frame.groundTruth_world_T_camera;
        const bool board = decodesTagOtherThan(detector, frame, kWallTag, found);
        run.boardFrames += board ? 1 : 0;
        // Without a board tag: Held for maxHeldFrames frames, then Lost (the wall tag is in every frame).
        framesWithoutMeasurement = board ? 0 : framesWithoutMeasurement + 1;
        const TrackingState expected = board                                                ? TrackingState::Tracking
                                       : framesWithoutMeasurement <= settings.maxHeldFrames ? TrackingState::Held
                                                                                            : TrackingState::Lost;
        EXPECT_EQ(result.state, expected)
            << "upsample " << upsample << ", frame " << frame.index << ": " << result.reason;
        if (result.state == TrackingState::Tracking) {
            ++run.tracked;
            budget.check(world, *result.world_T_camera, truth, frame.colourIntrinsics, frame.index);
            EXPECT_LE(result.uncertainty.worldCornerStdPx, settings.maxWorldCornerStdPx);
        } else {
            held += result.state == TrackingState::Held;
            lost += result.state == TrackingState::Lost;
            // Refused for the stated reason only.
            EXPECT_NE(std::string(result.reason).find("poorly determined"), std::string::npos)
                << "frame " << frame.index << ": " << result.reason;
            EXPECT_GT(result.uncertainty.worldCornerStdPx, settings.maxWorldCornerStdPx);
            smallestHeldStd = std::min(smallestHeldStd, result.uncertainty.worldCornerStdPx);
        }
    }
    std::printf("synth-orbit, upsample %d: board decoded in %d frames; %d tracked (%s), %d held, %d lost (smallest "
                "refused world-corner std %.1f px)\n",
                upsample, run.boardFrames, run.tracked, budget.describe().c_str(), held, lost, smallestHeldStd);
    EXPECT_EQ(frames, 40);
    return run;
}

TEST(SynthReplayTest, OrbitTracksExactlyWhenABoardTagIsDecodedAndUpsamplingDecodesMore) {
    const OrbitRun native = runOrbit(1), upsampled = runOrbit(2);
    EXPECT_GT(native.tracked, 0) << "the native-size run must exercise Tracking too";
    EXPECT_GT(upsampled.boardFrames, native.boardFrames) << "upsample 2 is what orbit.json relies on";
}

} // namespace
} // namespace lightskin::tracking
