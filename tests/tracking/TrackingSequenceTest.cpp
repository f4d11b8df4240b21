// The tracker over time: states when the tag leaves and re-enters the view, no silent flips when
// a tag turns through the ambiguous fronto-parallel region, bad input, and depth-aided refinement.
#include <lightskin/core/Error.h>
#include <lightskin/tracking/PoseTracker.h>
#include <lightskin/tracking/SyntheticTagImage.h>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <numbers>

namespace lightskin::tracking {
namespace {

double degrees(double radians) { return radians * 180.0 / std::numbers::pi; }
double radians(double degreesAngle) { return degreesAngle * std::numbers::pi / 180.0; }

const CameraIntrinsics camera = CameraIntrinsics::kinectV1Default();

SyntheticTagImageSettings fastNoisy(std::uint64_t seed) {
    SyntheticTagImageSettings settings;
    settings.supersampling = 2; // sequences: speed over the last 0.01 px
    settings.noiseSigma = 2.0;
    settings.noiseSeed = seed;
    return settings;
}

// The camera pans away from the tag (the tag leaves the image), stays away, and pans back.
TEST(TrackingSequenceTest, TagLeavesAndReentersTrackingHeldLostTracking) {
    const TagWorld world = TagWorld::singleTag(5, 0.16);
    TrackerSettings settings;
    settings.maxHeldFrames = 5;
    PoseTracker tracker = PoseTracker::create(world, settings);
    const glm::dvec3 eye(0.2, -0.3, 0.9);
    // Pan angle per frame: 0 for frames 0-5, 70 degrees (tag far outside the 57-degree view) for
    // frames 6-20, 0 again from frame 21.
    std::vector<TrackingState> states;
    TrackingResult result;
    std::optional<Pose> lastTrackedPose;
    for (int frame = 0; frame < 26; ++frame) {
        const double pan = frame >= 6 && frame <= 20 ? 70.0 : 0.0;
        const glm::dvec3 forward = glm::dvec3(-eye.x, -eye.y, -eye.z);
        const glm::dvec3 side = glm::normalize(glm::cross(forward, glm::dvec3(0.0, 1.0, 0.0)));
        const glm::dvec3 target =
            eye + std::cos(radians(pan)) * forward + std::sin(radians(pan)) * glm::length(forward) * side;
        const Pose truth = lookAt(eye, target, {0.0, 1.0, 0.0});
        const cv::Mat image =
            renderSyntheticTagImage(world, camera, truth, fastNoisy(static_cast<std::uint64_t>(frame) + 1));
        tracker.trackImageInto(image, camera, frame / 30.0, frame, result);
        states.push_back(result.state);
        switch (result.state) {
        case TrackingState::Tracking:
            ASSERT_TRUE(result.world_T_camera.has_value());
            EXPECT_LE(Pose::translationDistance(*result.world_T_camera, truth), 0.01) << "frame " << frame;
            EXPECT_EQ(result.tagsUsed, std::vector<int>{5});
            EXPECT_EQ(result.framesWithoutMeasurement, 0);
            lastTrackedPose = result.world_T_camera;
            break;
        case TrackingState::Held:
            // The last pose, unchanged, never a new one.
            ASSERT_TRUE(result.world_T_camera.has_value());
            ASSERT_TRUE(lastTrackedPose.has_value());
            EXPECT_DOUBLE_EQ(Pose::translationDistance(*result.world_T_camera, *lastTrackedPose), 0.0);
            EXPECT_FALSE(result.measured_world_T_camera.has_value());
            EXPECT_TRUE(result.tagsUsed.empty());
            EXPECT_STREQ(result.reason, "no tags detected");
            break;
        case TrackingState::Lost:
            EXPECT_FALSE(result.world_T_camera.has_value()) << "a pose while lost, frame " << frame;
            EXPECT_FALSE(result.measured_world_T_camera.has_value());
            break;
        case TrackingState::DepthTracked:
            ADD_FAILURE() << "frame " << frame << ": the tag tracker never depth-tracks (the room memory does)";
            break;
        }
        EXPECT_GE(result.timing.totalMs, result.timing.detectMs);
    }
    std::vector<TrackingState> expected;
    for (int frame = 0; frame < 26; ++frame) {
        if (frame < 6 || frame > 20)
            expected.push_back(TrackingState::Tracking);
        else if (frame <= 10)
            expected.push_back(TrackingState::Held); // 5 held frames: 6..10
        else
            expected.push_back(TrackingState::Lost);
    }
    EXPECT_EQ(states, expected);
}

// A tag turns about its vertical axis from -30 to +30 degrees (through fronto-parallel, where the
// two pose solutions swap places) at 60 degrees/s, a 10 cm tag at 1.3 m (~40 px). No frame may
// report the flipped solution, consecutive poses move by the 2-degree step plus noise only, and
// near fronto-parallel, where a 40 px tag's orientation is uncertain by several degrees, the
// tracker's reported uncertainty covers the error.
TEST(TrackingSequenceTest, TurningThroughFrontoParallelNeverJumpsToTheFlippedPose) {
    const TagWorld world = TagWorld::singleTag(2, 0.10);
    PoseTracker tracker = PoseTracker::create(world);
    TrackingResult result;
    int ambiguousFrames = 0;
    double worstError = 0.0;
    double worstRatioToStd = 0.0;
    std::optional<Pose> previous;
    for (int frame = 0; frame <= 30; ++frame) {
        const double yaw = -30.0 + 2.0 * frame;
        const glm::dvec3 eye = 1.3 * glm::dvec3(std::sin(radians(yaw)), 0.05, std::cos(radians(yaw)));
        const Pose truth = lookAt(eye, {0.0, 0.0, 0.0}, {0.0, 1.0, 0.0});
        tracker.trackImageInto(
            renderSyntheticTagImage(world, camera, truth, fastNoisy(static_cast<std::uint64_t>(frame) + 50)), camera,
            frame / 30.0, frame, result);
        ASSERT_EQ(result.state, TrackingState::Tracking) << "frame " << frame << ": " << result.reason;
        ambiguousFrames += result.ambiguous ? 1 : 0;
        const double error = degrees(Pose::rotationAngleBetween(*result.world_T_camera, truth));
        // Not flipped: the accepted measurement is the candidate nearest the truth, and the error
        // is either small or within 2.5x the uncertainty the tracker reports for the frame.
        const PoseMeasurement m = estimatePose(tracker.lastDetections(), world, camera);
        ASSERT_EQ(m.candidates.size(), 2u);
        const double measuredError = degrees(Pose::rotationAngleBetween(*result.measured_world_T_camera, truth));
        for (const PoseCandidate& candidate : m.candidates)
            EXPECT_LE(measuredError, degrees(Pose::rotationAngleBetween(candidate.world_T_camera, truth)) + 1e-6)
                << "frame " << frame << " yaw " << yaw << ": the flipped solution was reported";
        EXPECT_TRUE(measuredError < 2.0 || measuredError < 2.5 * result.uncertainty.rotationStdDegrees)
            << "frame " << frame << " yaw " << yaw << " error " << measuredError << " std "
            << result.uncertainty.rotationStdDegrees;
        worstRatioToStd = std::max(worstRatioToStd, measuredError / result.uncertainty.rotationStdDegrees);
        // The filtered output carries the previous frames' errors for a while; it stays bounded.
        EXPECT_LT(error, 6.0) << "frame " << frame;
        worstError = std::max(worstError, error);
        if (previous) {
            // Consecutive outputs differ by the 2-degree step plus noise, never by a flip.
            EXPECT_LT(degrees(Pose::rotationAngleBetween(*previous, *result.world_T_camera)), 6.0) << "frame " << frame;
        }
        previous = result.world_T_camera;
    }
    std::printf("turn through fronto-parallel: %d of 31 frames ambiguous, worst filtered rotation error %.2f deg, "
                "worst measurement error / reported std %.2f\n",
                ambiguousFrames, worstError, worstRatioToStd);
}

TEST(TrackingSequenceTest, NoTagsAndUnknownIdsAreLostWithAReason) {
    const TagWorld world = TagWorld::singleTag(5, 0.16);
    PoseTracker tracker = PoseTracker::create(world);
    TrackingResult result;
    const cv::Mat blank(camera.height, camera.width, CV_8UC1, cv::Scalar(128));
    tracker.trackImageInto(blank, camera, 0.0, 0, result);
    EXPECT_EQ(result.state, TrackingState::Lost);
    EXPECT_FALSE(result.world_T_camera.has_value());
    EXPECT_STREQ(result.reason, "no tags detected");
    EXPECT_TRUE(std::isnan(result.reprojectionErrorPx));

    // Tags 8 and 9 are visible, the world only knows tag 5.
    std::vector<WorldTag> others{{8, 0.1, Pose({1.0, 0.0, 0.0, 0.0}, {-0.1, 0.0, 0.0})},
                                 {9, 0.1, Pose({1.0, 0.0, 0.0, 0.0}, {0.1, 0.0, 0.0})}};
    const Pose view = lookAt({0.1, 0.1, 0.8}, {0.0, 0.0, 0.0}, {0.0, 1.0, 0.0});
    const cv::Mat image = renderSyntheticTagImage(TagWorld::bundle(others), camera, view, fastNoisy(3));
    tracker.trackImageInto(image, camera, 1.0 / 30.0, 1, result);
    EXPECT_EQ(result.state, TrackingState::Lost);
    EXPECT_FALSE(result.world_T_camera.has_value());
    EXPECT_STREQ(result.reason, "no tag of the world detected");
    EXPECT_EQ(result.unknownTags, (std::vector<int>{8, 9}));
    EXPECT_TRUE(result.tagsUsed.empty());
}

TEST(TrackingSequenceTest, BadFramesThrowNamingTheFrame) {
    PoseTracker tracker = PoseTracker::create(TagWorld::singleTag(5, 0.16));
    TrackingResult result;
    const cv::Mat small(240, 320, CV_8UC1, cv::Scalar(128));
    try {
        tracker.trackImageInto(small, camera, 0.0, 17, result);
        FAIL();
    } catch (const Error& error) {
        EXPECT_EQ(error.frame(), 17);
        EXPECT_NE(error.cause().find("320x240"), std::string::npos) << error.cause();
    }
    EXPECT_THROW(tracker.trackImageInto(cv::Mat(480, 640, CV_8UC1), CameraIntrinsics{}, 0.0, 0, result), Error);
    EXPECT_THROW(tracker.trackImageInto(cv::Mat(480, 640, CV_16UC1), camera, 0.0, 0, result), Error);
    RgbdFrame noColour;
    EXPECT_THROW(tracker.trackInto(noColour, result), Error);
    TrackerSettings bad;
    bad.detector.quadDecimate = 0.5f;
    EXPECT_THROW(PoseTracker::create(TagWorld::singleTag(5, 0.16), bad), Error);
    bad = {};
    bad.detector.maxHamming = 3;
    EXPECT_THROW(PoseTracker::create(TagWorld::singleTag(5, 0.16), bad), Error);
    for (const int upsample : {0, 5}) {
        bad = {};
        bad.detector.upsample = upsample;
        EXPECT_THROW(PoseTracker::create(TagWorld::singleTag(5, 0.16), bad), Error) << upsample;
    }
    bad = {};
    bad.maxWorldCornerStdPx = 0.0;
    EXPECT_THROW(PoseTracker::create(TagWorld::singleTag(5, 0.16), bad), Error);
}

TEST(TrackingSequenceTest, GroundTruthPassThroughForReplay) {
    RgbdFrame frame;
    frame.index = 4;
    EXPECT_EQ(PoseTracker::fromGroundTruth(frame).state, TrackingState::Lost);
    EXPECT_FALSE(PoseTracker::fromGroundTruth(frame).world_T_camera.has_value());
    frame.groundTruth_world_T_camera = Pose({1.0, 0.0, 0.0, 0.0}, {1.0, 2.0, 3.0});
    const TrackingResult result = PoseTracker::fromGroundTruth(frame);
    EXPECT_EQ(result.state, TrackingState::Tracking);
    EXPECT_EQ(result.frameIndex, 4);
    EXPECT_DOUBLE_EQ(result.world_T_camera->translation().z, 3.0);
}

/// Registered depth (millimetres) of the world's z = 0 plane seen from `world_T_camera`, with
/// Kinect-like axial noise (Nguyen et al. 2012: 1.2 mm + 1.9 mm (z - 0.4)^2) and 1 mm quantisation.
cv::Mat planeDepth(const Pose& world_T_camera, std::uint64_t seed) {
    const Pose camera_T_world = world_T_camera.inverse();
    const glm::dvec3 normal = camera_T_world.transformDirection({0.0, 0.0, 1.0});
    const glm::dvec3 origin = camera_T_world.translation();
    cv::RNG rng(seed);
    cv::Mat depth(camera.height, camera.width, CV_16UC1);
    for (int v = 0; v < camera.height; ++v) {
        for (int u = 0; u < camera.width; ++u) {
            const glm::dvec3 ray = camera.backProject(u, v, 1.0);
            const double z = glm::dot(normal, origin) / glm::dot(normal, ray);
            const double sigma = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
            const double noisyZ = z + rng.gaussian(sigma);
            depth.at<std::uint16_t>(v, u) =
                z > 0.0 ? cv::saturate_cast<std::uint16_t>(std::lround(noisyZ * 1000.0)) : 0;
        }
    }
    return depth;
}

// A small (5 cm, ~35 px) tag seen nearly fronto-parallel at 0.75 m: the image alone leaves its
// tilt weakly determined; the registered depth over the tag fixes it.
TEST(TrackingSequenceTest, DepthAidedRefinementCorrectsTilt) {
    const TagWorld world = TagWorld::singleTag(1, 0.05);
    double sumWithout = 0.0, sumWith = 0.0;
    int refined = 0;
    constexpr int views = 6;
    for (int i = 0; i < views; ++i) {
        const double azimuth = 60.0 * i;
        const glm::dvec3 target(0.0, 0.0, 0.0);
        const glm::dvec3 eye =
            0.75 * glm::dvec3(std::sin(radians(4.0)) * std::cos(radians(azimuth)),
                              std::sin(radians(4.0)) * std::sin(radians(azimuth)), std::cos(radians(4.0)));
        const Pose truth = lookAt(eye, target, {0.0, 1.0, 0.0});
        RgbdFrame frame;
        frame.index = i;
        cv::cvtColor(renderSyntheticTagImage(world, camera, truth, fastNoisy(static_cast<std::uint64_t>(i) + 200)),
                     frame.colour, cv::COLOR_GRAY2BGR);
        frame.depth = planeDepth(truth, static_cast<std::uint64_t>(i) + 300);
        frame.colourIntrinsics = camera;
        frame.depthIntrinsics = camera;
        frame.depthScaleMetres = 0.001;
        frame.registration = DepthRegistration::RegisteredToColour;

        TrackerSettings settings;
        settings.filter.enabled = false;
        PoseTracker imageOnly = PoseTracker::create(world, settings);
        settings.useDepth = true;
        PoseTracker withDepth = PoseTracker::create(world, settings);
        const TrackingResult a = imageOnly.track(frame);
        const TrackingResult b = withDepth.track(frame);
        ASSERT_EQ(a.state, TrackingState::Tracking);
        ASSERT_EQ(b.state, TrackingState::Tracking);
        EXPECT_FALSE(a.depthRefined);
        refined += b.depthRefined ? 1 : 0;
        sumWithout += degrees(Pose::rotationAngleBetween(*a.world_T_camera, truth));
        const double withError = degrees(Pose::rotationAngleBetween(*b.world_T_camera, truth));
        sumWith += withError;
        EXPECT_LT(withError, 1.0) << "view " << i;
        // The distance to the tag stays right.
        EXPECT_NEAR(glm::length(b.world_T_camera->translation()), 0.75, 0.005);
    }
    std::printf("depth-aided refinement, 5 cm tag at 0.75 m, 4 degrees off-normal: mean rotation error %.2f deg "
                "image only, %.2f deg with depth\n",
                sumWithout / views, sumWith / views);
    EXPECT_EQ(refined, views);
    EXPECT_LT(sumWith, sumWithout);
}

// Depth that is not of the tag (here: a wall 30 cm behind it, as with a hole or a bad registration)
// must be refused, leaving the image pose.
TEST(TrackingSequenceTest, DepthThatDisagreesIsIgnored) {
    const TagWorld world = TagWorld::singleTag(1, 0.08);
    const Pose truth = lookAt({0.1, 0.05, 0.7}, {0.0, 0.0, 0.0}, {0.0, 1.0, 0.0});
    RgbdFrame frame;
    cv::cvtColor(renderSyntheticTagImage(world, camera, truth, fastNoisy(9)), frame.colour, cv::COLOR_GRAY2BGR);
    // The plane z = -0.3 of the world is the plane z = 0 of a frame shifted by +0.3 along z.
    frame.depth = planeDepth(Pose({1.0, 0.0, 0.0, 0.0}, {0.0, 0.0, 0.3}) * truth, 4);
    frame.colourIntrinsics = camera;
    frame.depthIntrinsics = camera;
    TrackerSettings settings;
    settings.useDepth = true;
    PoseTracker tracker = PoseTracker::create(world, settings);
    const TrackingResult result = tracker.track(frame);
    ASSERT_EQ(result.state, TrackingState::Tracking);
    EXPECT_FALSE(result.depthRefined);
    // Where the tag is in the camera: the image's answer, not pulled 30 cm back by the wall.
    EXPECT_LT(glm::length(result.world_T_camera->inverse().translation() - truth.inverse().translation()), 0.005);
}

} // namespace
} // namespace lightskin::tracking

namespace lightskin::tracking {
namespace {

// A lens with real distortion (TUM fr1's coefficients): the ideal rendering is warped into the
// distorted image, and both undistortion modes must give back the accuracy of an ideal camera.
TEST(TrackingSequenceTest, UndistortionOfCornersAndOfTheImage) {
    CameraIntrinsics lens = camera;
    lens.distortion = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633}; // TUM fr1 (Freiburg 1 calibration)
    ASSERT_TRUE(lens.hasDistortion());
    const TagWorld world = TagWorld::singleTag(4, 0.16);
    // The tag off the image centre (near pixel (422, 146)), where the distortion is strong.
    const Pose truth = lookAt({0.35, -0.2, 0.75}, {-0.2, -0.14, 0.0}, {0.0, 1.0, 0.0});
    SyntheticTagImageSettings render;
    render.noiseSigma = 2.0;
    const cv::Mat ideal = renderSyntheticTagImage(world, camera, truth, render);
    // Distorted pixel -> where that ray lands in the ideal image (undistortPoints with P = K).
    std::vector<cv::Point2f> distortedPixels;
    for (int v = 0; v < camera.height; ++v)
        for (int u = 0; u < camera.width; ++u)
            distortedPixels.emplace_back(static_cast<float>(u), static_cast<float>(v));
    std::vector<cv::Point2f> idealPixels;
    const cv::Matx33d k(camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0);
    cv::undistortPoints(distortedPixels, idealPixels, k, lens.distortion, cv::noArray(), k);
    cv::Mat mapX(camera.height, camera.width, CV_32FC1), mapY(camera.height, camera.width, CV_32FC1);
    for (int v = 0; v < camera.height; ++v) {
        for (int u = 0; u < camera.width; ++u) {
            const cv::Point2f& p = idealPixels[static_cast<std::size_t>(v * camera.width + u)];
            mapX.at<float>(v, u) = p.x;
            mapY.at<float>(v, u) = p.y;
        }
    }
    cv::Mat distorted;
    cv::remap(ideal, distorted, mapX, mapY, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(128));

    for (const Undistortion mode : {Undistortion::Corners, Undistortion::Image}) {
        TrackerSettings settings;
        settings.undistortion = mode;
        PoseTracker tracker = PoseTracker::create(world, settings);
        TrackingResult result;
        tracker.trackImageInto(distorted, lens, 0.0, 0, result);
        ASSERT_EQ(result.state, TrackingState::Tracking) << result.reason;
        const double position =
            glm::length(result.world_T_camera->inverse().translation() - truth.inverse().translation());
        const double rotation = degrees(Pose::rotationAngleBetween(*result.world_T_camera, truth));
        std::printf("distorted lens, %s undistortion: position %.2f mm, rotation %.3f deg\n",
                    mode == Undistortion::Corners ? "corner" : "image", position * 1000.0, rotation);
        EXPECT_LE(position, 0.002 * 0.85);
        EXPECT_LE(rotation, 0.5);

        // Ignoring the distortion is measurably worse: the test can tell the difference.
        if (mode == Undistortion::Corners) {
            PoseTracker naive = PoseTracker::create(world, settings);
            naive.trackImageInto(distorted, camera, 0.0, 0, result);
            ASSERT_EQ(result.state, TrackingState::Tracking);
            const double naivePosition =
                glm::length(result.world_T_camera->inverse().translation() - truth.inverse().translation());
            std::printf("distorted lens, distortion ignored: position %.2f mm\n", naivePosition * 1000.0);
            EXPECT_GT(naivePosition, 3.0 * std::max(position, 0.0005));
        }
    }
}

} // namespace
} // namespace lightskin::tracking
