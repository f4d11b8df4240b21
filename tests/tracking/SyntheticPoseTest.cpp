// Synthetic images with exact ground truth: accuracy for well-conditioned views, honest states
// and flags for bad ones. Images come from renderSyntheticTagImage (exact homographies of the real
// tag bitmaps, 4x4 supersampled) with mild sensor noise.
#include <lightskin/tracking/PoseTracker.h>
#include <lightskin/tracking/SyntheticTagImage.h>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>

namespace lightskin::tracking {
namespace {

double degrees(double radians) { return radians * 180.0 / std::numbers::pi; }
double radians(double degreesAngle) { return degreesAngle * std::numbers::pi / 180.0; }

const CameraIntrinsics camera = CameraIntrinsics::kinectV1Default(); // 640x480, f 525

/// A camera `distance` metres from the tag centre, its viewing direction tilted by `tilt` degrees
/// from the tag normal, towards azimuth `azimuth` degrees, looking at a point slightly off the
/// centre (so the tag is not at the principal point).
Pose viewOfTag(double distance, double tilt, double azimuth, const glm::dvec3& target = {0.01, -0.02, 0.0}) {
    const double t = radians(tilt);
    const double a = radians(azimuth);
    const glm::dvec3 eye =
        target + distance * glm::dvec3(std::sin(t) * std::cos(a), std::sin(t) * std::sin(a), std::cos(t));
    return lookAt(eye, target, {std::sin(a + 0.3), std::cos(a + 0.3), 0.0});
}

// Position error = error of the world origin's position in the camera frame (PnP's translation,
// what "mm per metre of distance" measures). The camera's position in the world additionally moves
// by distance x rotation error (a lever arm: 0.3 degrees at 1 m is 5 mm), reported separately.
struct Errors {
    double positionMetres = 0.0;
    double rotationDegrees = 0.0;
    double cameraPositionMetres = 0.0;
};

Errors errorsOf(const Pose& estimate, const Pose& truth) {
    return {Pose::translationDistance(estimate.inverse(), truth.inverse()),
            degrees(Pose::rotationAngleBetween(estimate, truth)), Pose::translationDistance(estimate, truth)};
}

SyntheticTagImageSettings noisy(std::uint64_t seed) {
    SyntheticTagImageSettings settings;
    settings.noiseSigma = 2.0;
    settings.noiseSeed = seed;
    return settings;
}

TrackingResult trackOnce(const TagWorld& world, const cv::Mat& image, const TrackerSettings& settingsIn = {}) {
    const TrackerSettings& settings = settingsIn;
    PoseTracker tracker = PoseTracker::create(world, settings);
    TrackingResult result;
    tracker.trackImageInto(image, camera, 0.0, 0, result);
    return result;
}

// Well-conditioned: 16 cm tag at 0.5-1.2 m (70-170 px), viewed 25-55 degrees off its normal from
// three sides, default detector settings (decimate 2 + edge refinement), noise sigma 2.
// Requirement: position error <= 2 mm per metre of distance, rotation error <= 0.5 degrees.
TEST(SyntheticPoseTest, WellConditionedSingleTagViewsAreAccurate) {
    const TagWorld world = TagWorld::singleTag(7, 0.16);
    double worstPositionPerMetre = 0.0;
    double worstRotation = 0.0;
    double worstCameraPositionPerMetre = 0.0;
    double worstStd = 0.0;
    std::uint64_t seed = 1;
    for (const double distance : {0.5, 0.8, 1.2}) {
        for (const double tilt : {25.0, 40.0, 55.0}) {
            for (const double azimuth : {0.0, 120.0, 240.0}) {
                const Pose truth = viewOfTag(distance, tilt, azimuth);
                const cv::Mat image = renderSyntheticTagImage(world, camera, truth, noisy(seed++));
                const TrackingResult result = trackOnce(world, image);
                ASSERT_EQ(result.state, TrackingState::Tracking)
                    << "d " << distance << " tilt " << tilt << " az " << azimuth << ": " << result.reason;
                ASSERT_TRUE(result.world_T_camera.has_value());
                const Errors e = errorsOf(*result.world_T_camera, truth);
                worstPositionPerMetre = std::max(worstPositionPerMetre, e.positionMetres / distance);
                worstRotation = std::max(worstRotation, e.rotationDegrees);
                EXPECT_LE(e.positionMetres, 0.002 * distance)
                    << "d " << distance << " tilt " << tilt << " az " << azimuth << " rot " << e.rotationDegrees;
                EXPECT_LE(e.rotationDegrees, 0.5) << "d " << distance << " tilt " << tilt << " az " << azimuth;
                EXPECT_FALSE(result.ambiguous)
                    << "d " << distance << " tilt " << tilt << " ratio " << result.ambiguityRatio;
                EXPECT_LT(result.reprojectionErrorPx, 0.5);
                // The reported uncertainty is honest: the true rotation error is within 4 sigma.
                EXPECT_LE(e.rotationDegrees, 4.0 * result.uncertainty.rotationStdDegrees + 0.02);
                worstCameraPositionPerMetre = std::max(worstCameraPositionPerMetre, e.cameraPositionMetres / distance);
                worstStd = std::max(worstStd, result.uncertainty.rotationStdDegrees);
                EXPECT_EQ(result.tagsUsed, std::vector<int>{7});
            }
        }
    }
    std::printf("well-conditioned single tag: worst position error %.2f mm/m, worst rotation error %.3f deg "
                "(camera position in the world %.2f mm/m; largest reported rotation std %.3f deg)\n",
                worstPositionPerMetre * 1000.0, worstRotation, worstCameraPositionPerMetre * 1000.0, worstStd);
}

// A bundle of four tags on a 40 cm square seen from 1.5 m: joint PnP over 16 corners.
TEST(SyntheticPoseTest, BundleViewsAreAccurateAndUnambiguous) {
    std::vector<WorldTag> tags;
    int id = 10;
    for (const double x : {-0.2, 0.2})
        for (const double y : {-0.2, 0.2}) tags.push_back({id++, 0.12, Pose({1.0, 0.0, 0.0, 0.0}, {x, y, 0.0})});
    const TagWorld world = TagWorld::bundle(tags);
    std::uint64_t seed = 100;
    for (const double tilt : {0.0, 20.0, 45.0}) {
        for (const double azimuth : {30.0, 200.0}) {
            const Pose truth = viewOfTag(1.5, tilt, azimuth, {0.0, 0.0, 0.0});
            const TrackingResult result =
                trackOnce(world, renderSyntheticTagImage(world, camera, truth, noisy(seed++)));
            ASSERT_EQ(result.state, TrackingState::Tracking) << result.reason;
            EXPECT_EQ(result.tagsUsed.size(), 4u);
            const Errors e = errorsOf(*result.world_T_camera, truth);
            EXPECT_LE(e.positionMetres, 0.002 * 1.5) << "tilt " << tilt << " az " << azimuth;
            EXPECT_LE(e.rotationDegrees, 0.5) << "tilt " << tilt << " az " << azimuth;
            EXPECT_FALSE(result.ambiguous) << "tilt " << tilt << " ratio " << result.ambiguityRatio;
        }
    }
}

// Near-fronto-parallel single tag (2 degrees): the orientation is weakly determined (the planar
// ambiguity region). The tracker must say so: its reported rotation uncertainty exceeds the
// 0.5-degree requirement (so consumers know not to rely on it), the actual error is within 3 sigma
// of what it reports, and what the view does determine - where the tag is in the camera - is accurate.
TEST(SyntheticPoseTest, NearFrontoParallelViewReportsItsWeakOrientation) {
    const TagWorld world = TagWorld::singleTag(3, 0.16);
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
        const Pose truth = viewOfTag(1.0, 2.0, 60.0 * static_cast<double>(seed));
        const TrackingResult result = trackOnce(world, renderSyntheticTagImage(world, camera, truth, noisy(seed)));
        ASSERT_EQ(result.state, TrackingState::Tracking) << result.reason;
        const Errors e = errorsOf(*result.world_T_camera, truth);
        std::printf("fronto-parallel seed %d: ratio %.2f%s, rotation error %.2f deg (reported std %.2f), tag position "
                    "error %.2f mm\n",
                    static_cast<int>(seed), result.ambiguityRatio, result.ambiguous ? " (ambiguous)" : "",
                    e.rotationDegrees, result.uncertainty.rotationStdDegrees, e.positionMetres * 1000.0);
        EXPECT_GT(result.uncertainty.rotationStdDegrees, 0.5);
        EXPECT_LE(e.rotationDegrees, 3.0 * result.uncertainty.rotationStdDegrees);
        EXPECT_LE(e.positionMetres, 0.002);
    }
}

// Grazing view, 70 degrees off the normal: the tag is a thin trapezoid. It is still tracked, the
// view is unambiguous (strong perspective), and the error is within twice the well-conditioned bounds.
TEST(SyntheticPoseTest, GrazingSeventyDegreesIsTrackedWithBoundedError) {
    const TagWorld world = TagWorld::singleTag(3, 0.16);
    for (const double azimuth : {0.0, 90.0, 200.0}) {
        const Pose truth = viewOfTag(0.7, 70.0, azimuth);
        const TrackingResult result = trackOnce(
            world, renderSyntheticTagImage(world, camera, truth, noisy(static_cast<std::uint64_t>(azimuth) + 7)));
        ASSERT_EQ(result.state, TrackingState::Tracking) << "az " << azimuth << ": " << result.reason;
        const Errors e = errorsOf(*result.world_T_camera, truth);
        std::printf("grazing 70 deg az %.0f: position %.2f mm/m, rotation %.3f deg, ratio %.1f, reprojection %.2f px\n",
                    azimuth, e.positionMetres / 0.7 * 1000.0, e.rotationDegrees, result.ambiguityRatio,
                    result.reprojectionErrorPx);
        EXPECT_LE(e.positionMetres, 0.004 * 0.7) << "az " << azimuth;
        EXPECT_LE(e.rotationDegrees, 1.0) << "az " << azimuth;
        EXPECT_FALSE(result.ambiguous);
    }
}

// 12 px tags (16 cm at 7 m): decimate 2 does not find them and the tracker says "no tags"; with
// decimate 1 they are found, and the pose is honest: ambiguous, with a few percent of distance error.
TEST(SyntheticPoseTest, TwelvePixelTagsNeedDecimateOneAndAreReportedHonestly) {
    const TagWorld world = TagWorld::singleTag(3, 0.16);
    const double distance = camera.fx * 0.16 / 12.0; // black border 12 px wide when fronto-parallel
    const Pose truth = viewOfTag(distance, 20.0, 45.0, {0.3, -0.2, 0.0});
    const cv::Mat image = renderSyntheticTagImage(world, camera, truth, noisy(5));

    const TrackingResult coarse = trackOnce(world, image);
    EXPECT_EQ(coarse.state, TrackingState::Lost);
    EXPECT_FALSE(coarse.world_T_camera.has_value());
    EXPECT_STREQ(coarse.reason, "no tags detected");

    TrackerSettings fine;
    fine.detector.quadDecimate = 1.0f;
    const TrackingResult result = trackOnce(world, image, fine);
    ASSERT_EQ(result.state, TrackingState::Tracking) << result.reason;
    const Errors e = errorsOf(*result.world_T_camera, truth);
    const double tagDistanceError = std::abs(glm::length(result.world_T_camera->inverse().translation()) -
                                             glm::length(truth.inverse().translation()));
    std::printf("12 px tag at %.1f m: ratio %.2f, tag distance error %.0f mm, rotation error %.1f deg\n", distance,
                result.ambiguityRatio, tagDistanceError * 1000.0, e.rotationDegrees);
    EXPECT_TRUE(result.ambiguous) << "ratio " << result.ambiguityRatio;
    EXPECT_LE(tagDistanceError, 0.03 * distance);
}

// A hand over one corner of a single tag: the border is broken, no detection, the tracker says
// Lost with no pose. The same hand over one tag of a bundle: tracking goes on with the others.
TEST(SyntheticPoseTest, PartialOcclusion) {
    const TagWorld single = TagWorld::singleTag(3, 0.16);
    const Pose truth = viewOfTag(0.8, 30.0, 20.0, {0.0, 0.0, 0.0});
    cv::Mat image = renderSyntheticTagImage(single, camera, truth, noisy(9));
    const glm::dvec2 corner = camera.project(truth.inverse().transformPoint({0.08, 0.08, 0.0}));
    cv::circle(image, cv::Point(static_cast<int>(corner.x), static_cast<int>(corner.y)), 20, cv::Scalar(90),
               cv::FILLED);
    const TrackingResult occluded = trackOnce(single, image);
    EXPECT_EQ(occluded.state, TrackingState::Lost);
    EXPECT_FALSE(occluded.world_T_camera.has_value());
    EXPECT_STREQ(occluded.reason, "no tags detected");

    std::vector<WorldTag> tags{{1, 0.1, Pose({1.0, 0.0, 0.0, 0.0}, {-0.15, 0.0, 0.0})},
                               {2, 0.1, Pose({1.0, 0.0, 0.0, 0.0}, {0.15, 0.0, 0.0})}};
    const TagWorld bundle = TagWorld::bundle(tags);
    cv::Mat bundleImage = renderSyntheticTagImage(bundle, camera, truth, noisy(10));
    const glm::dvec2 centre = camera.project(truth.inverse().transformPoint({0.15, 0.0, 0.0}));
    cv::rectangle(bundleImage, cv::Rect(static_cast<int>(centre.x) - 10, static_cast<int>(centre.y) - 80, 80, 160),
                  cv::Scalar(60), cv::FILLED);
    const TrackingResult result = trackOnce(bundle, bundleImage);
    ASSERT_EQ(result.state, TrackingState::Tracking) << result.reason;
    EXPECT_EQ(result.tagsUsed, std::vector<int>{1});
    const Errors e = errorsOf(*result.world_T_camera, truth);
    EXPECT_LE(e.positionMetres, 0.002 * 0.8);
    EXPECT_LE(e.rotationDegrees, 0.5);
}

// Motion blur of 4 px (a camera panning at ~120 px/s with a 1/30 s exposure): still tracked, with
// the error bounds of the well-conditioned case doubled. At 12 px the detector loses the tag and
// the tracker says so instead of reporting a pose.
TEST(SyntheticPoseTest, MotionBlur) {
    const TagWorld world = TagWorld::singleTag(3, 0.16);
    const Pose truth = viewOfTag(0.8, 35.0, 100.0);
    SyntheticTagImageSettings settings = noisy(11);
    settings.motionBlurPx = 4.0;
    settings.motionBlurAngleDegrees = 10.0;
    const TrackingResult result = trackOnce(world, renderSyntheticTagImage(world, camera, truth, settings));
    ASSERT_EQ(result.state, TrackingState::Tracking) << result.reason;
    const Errors e = errorsOf(*result.world_T_camera, truth);
    std::printf("motion blur 4 px: position %.2f mm/m, rotation %.3f deg, reprojection %.2f px\n",
                e.positionMetres / 0.8 * 1000.0, e.rotationDegrees, result.reprojectionErrorPx);
    EXPECT_LE(e.positionMetres, 0.004 * 0.8);
    EXPECT_LE(e.rotationDegrees, 1.0);

    settings.motionBlurPx = 12.0;
    const TrackingResult heavy = trackOnce(world, renderSyntheticTagImage(world, camera, truth, settings));
    if (heavy.state == TrackingState::Tracking) {
        const Errors h = errorsOf(*heavy.world_T_camera, truth);
        std::printf("motion blur 12 px: tracked, position %.2f mm/m, rotation %.3f deg\n",
                    h.positionMetres / 0.8 * 1000.0, h.rotationDegrees);
        EXPECT_LE(h.rotationDegrees, 2.0);
    } else {
        std::printf("motion blur 12 px: %s (%s)\n", toString(heavy.state), heavy.reason);
        EXPECT_FALSE(heavy.world_T_camera.has_value());
    }
}

// A bundle seen through one small, distant tag (a 20 cm tag 3 m away, ~35 px, nearly head-on)
// while the bundle's other tag is 2.5 m to the side: the seen tag's corners fit, but the rotation is
// so poorly determined that the other tag's corners could be anywhere within tens of pixels. Such
// a pose is not reported as Tracking (the first frame stays Lost, with the reason and the
// uncertainty); the same view of a single-tag world, whose content is near that tag, is tracked.
TEST(SyntheticPoseTest, BundleSeenOnlyThroughOneDistantTagIsNotTracked) {
    std::vector<WorldTag> tags{{4, 0.2, Pose({1.0, 0.0, 0.0, 0.0}, {0.0, 0.0, 0.0})},
                               {5, 0.2, Pose({1.0, 0.0, 0.0, 0.0}, {2.5, 0.0, 0.0})}};
    const TagWorld bundle = TagWorld::bundle(tags);
    const Pose truth = viewOfTag(3.0, 5.0, 200.0, {0.0, 0.0, 0.0});
    const cv::Mat image = renderSyntheticTagImage(bundle, camera, truth, noisy(31));

    const TrackingResult single = trackOnce(TagWorld::singleTag(4, 0.2), image);
    ASSERT_EQ(single.state, TrackingState::Tracking) << single.reason;
    EXPECT_LT(single.uncertainty.worldCornerStdPx, 1.0);

    const TrackingResult result = trackOnce(bundle, image);
    std::printf("bundle through one tag at 3 m: rotation std %.2f deg, world-corner std %.1f px: %s (%s)\n",
                result.uncertainty.rotationStdDegrees, result.uncertainty.worldCornerStdPx, toString(result.state),
                result.reason);
    EXPECT_EQ(result.state, TrackingState::Lost);
    EXPECT_FALSE(result.world_T_camera.has_value());
    EXPECT_NE(std::string(result.reason).find("poorly determined"), std::string::npos) << result.reason;
    EXPECT_GT(result.uncertainty.worldCornerStdPx, TrackerSettings{}.maxWorldCornerStdPx);

    // The check switched off: the same frame is tracked (with a pose the uncertainty says is weak).
    TrackerSettings off;
    off.maxWorldCornerStdPx = std::numeric_limits<double>::infinity();
    EXPECT_EQ(trackOnce(bundle, image, off).state, TrackingState::Tracking);
}

// DetectorSettings::upsample: the corners found in the enlarged image, mapped back, agree with
// those found at native size and with the exact projection. (What it gains - blurred small tags at
// grazing angles the library misses at native size - is measured on synth-orbit's GL renders in
// SynthReplayTest; on these sharp box-filtered renders of 21-34 px tags at 60-70 degrees the
// library finds nearly all at native size: over 24 views, upsample 2 found one more and missed one.)
TEST(SyntheticPoseTest, UpsampledDetectionMapsCornersBack) {
    const TagWorld world = TagWorld::singleTag(3, 0.16);
    const Pose truth = viewOfTag(1.0, 40.0, 30.0);
    const cv::Mat image = renderSyntheticTagImage(world, camera, truth, noisy(41));
    for (const bool refine : {false, true}) {
        DetectorSettings settings;
        settings.quadDecimate = 1.0f;
        settings.refineCorners = refine;
        const auto native = TagDetector::create(settings).detect(image);
        settings.upsample = 2;
        const auto enlarged = TagDetector::create(settings).detect(image);
        ASSERT_EQ(native.size(), 1u);
        ASSERT_EQ(enlarged.size(), 1u);
        const double h = 0.08;
        const std::array<glm::dvec3, 4> tagCorners{glm::dvec3(-h, -h, 0.0), glm::dvec3(h, -h, 0.0),
                                                   glm::dvec3(h, h, 0.0), glm::dvec3(-h, h, 0.0)};
        double worstToNative = 0.0, worstToTruth = 0.0;
        for (std::size_t k = 0; k < 4; ++k) {
            const glm::dvec2 exact = camera.project(truth.inverse().transformPoint(tagCorners[k]));
            worstToNative = std::max(worstToNative, glm::length(enlarged[0].corners[k] - native[0].corners[k]));
            worstToTruth = std::max(worstToTruth, glm::length(enlarged[0].corners[k] - exact));
        }
        std::printf("upsample 2 (refineCorners %d): corners within %.3f px of native size, %.3f px of the truth\n",
                    refine ? 1 : 0, worstToNative, worstToTruth);
        EXPECT_LT(worstToNative, 0.3);
        EXPECT_LT(worstToTruth, 0.3);
    }
}

} // namespace
} // namespace lightskin::tracking

namespace lightskin::tracking {
namespace {

// A bundle whose config places tag 22 10 cm away from where it really is (a tag that was moved):
// its corners disagree with the other tags, it is dropped and named, and the pose comes from the rest.
TEST(SyntheticPoseTest, BundleDropsATagThatDisagrees) {
    std::vector<WorldTag> real{{20, 0.1, Pose({1.0, 0.0, 0.0, 0.0}, {-0.15, -0.1, 0.0})},
                               {21, 0.1, Pose({1.0, 0.0, 0.0, 0.0}, {0.15, -0.1, 0.0})},
                               {22, 0.1, Pose({1.0, 0.0, 0.0, 0.0}, {0.0, 0.15, 0.0})}};
    std::vector<WorldTag> configured = real;
    configured[2].world_T_tag = Pose({1.0, 0.0, 0.0, 0.0}, {0.1, 0.15, 0.0});
    const Pose truth = viewOfTag(0.9, 30.0, 40.0, {0.0, 0.0, 0.0});
    const cv::Mat image = renderSyntheticTagImage(TagWorld::bundle(real), camera, truth, noisy(21));
    const TrackingResult result = trackOnce(TagWorld::bundle(configured), image);
    ASSERT_EQ(result.state, TrackingState::Tracking) << result.reason;
    EXPECT_EQ(result.tagsUsed, (std::vector<int>{20, 21}));
    EXPECT_EQ(result.rejectedTags, std::vector<int>{22});
    const Errors e = errorsOf(*result.world_T_camera, truth);
    EXPECT_LE(e.positionMetres, 0.002 * 0.9);
    EXPECT_LE(e.rotationDegrees, 0.5);
}

} // namespace
} // namespace lightskin::tracking
