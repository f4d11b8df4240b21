#include <lightskin/core/Error.h>
#include <lightskin/synth/SceneDescription.h>

#include "TestPaths.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

namespace lightskin::synth {
namespace {

const char* minimalScene = R"({
  "format": "lightskin-synth-scene", "version": 1, "name": "minimal",
  "path": {"segments": [{"type": "hold", "frames": 2, "position": [1, 1, 1], "target": [2, 1, 1]}]}
})";

std::string withPath(const std::string& segments, const std::string& extra = "") {
    return R"({"format": "lightskin-synth-scene", "version": 1,)" + extra + R"( "path": {"fps": 30, "segments": [)" +
           segments + "]}}";
}

TEST(SceneDescriptionTest, ParsesDefaultsAndCountsFrames) {
    const SceneDescription scene = parseSceneDescription(minimalScene, "minimal.json");
    EXPECT_EQ(scene.name, "minimal");
    EXPECT_EQ(scene.path.frameCount(), 2);
    EXPECT_EQ(scene.intrinsics.width, 320);
    EXPECT_DOUBLE_EQ(scene.intrinsics.fx, 262.5); // kinect-v1 preset at half resolution
    EXPECT_DOUBLE_EQ(scene.intrinsics.cx, 159.5);
    EXPECT_FALSE(scene.noise.enabled);
}

TEST(SceneDescriptionTest, RejectsUnknownKeysWrongTypesAndBadRanges) {
    const auto expectError = [](const std::string& text, const std::string& fragment) {
        try {
            parseSceneDescription(text, "bad.json");
            ADD_FAILURE() << "no error for " << text;
        } catch (const Error& error) {
            EXPECT_EQ(error.source(), "bad.json");
            EXPECT_NE(std::string(error.what()).find(fragment), std::string::npos) << error.what();
        }
    };
    const std::string hold = R"({"type": "hold", "frames": 2, "position": [1, 1, 1], "target": [2, 1, 1]})";
    expectError("{not json", "not valid JSON");
    expectError(R"({"format": "other", "version": 1})", "format");
    expectError(withPath(hold, R"("colour": 1,)"), "colour: unknown key");
    expectError(withPath(R"({"type": "hold", "frames": 2, "positon": [1, 1, 1]})"), "positon: unknown key");
    expectError(withPath(R"({"type": "spin", "frames": 2})"), "path.segments[0].type");
    expectError(withPath(R"({"type": "hold", "frames": 0})"), "frames");
    expectError(withPath(hold, R"("room": {"size": [1, 2]},)"), "room.size");
    expectError(withPath(hold, R"("camera": {"width": "320"},)"), "camera.width: expected an integer");
    expectError(withPath(hold, R"("tags": [{"id": 3, "facing": [0, 0, 0]}],)"), "facing");
    expectError(withPath(hold, R"("tags": [{"id": 3}, {"id": 3}],)"), "appears twice");
    expectError(withPath(""), "at least one segment");
    const std::string areaLight = R"({"type": "area", "position": [2, 2, 2.5], "facing": [0, 0, -1], "samples": 8})";
    expectError(withPath(hold, R"("lights": [)" + areaLight + "," + areaLight + "," + areaLight + "," + areaLight + "," + areaLight + "],"),
                "320 light samples");
    expectError(withPath(hold, R"("camera": {"width": 100000},)"), "camera.width");
    expectError(withPath(R"({"type": "hold", "frames": 100001})"), "frames");
}

TEST(SceneDescriptionTest, TagBoardExpandsRowByRowFromTheTopLeft) {
    const SceneDescription scene = parseSceneDescription(
        withPath(R"({"type": "hold", "position": [1, 1, 1], "target": [2, 1, 1]})",
                 R"("tagBoards": [{"firstId": 4, "rows": 2, "columns": 3, "size": 0.1, "spacing": 0.2,
                     "position": [2, 2, 0.75], "facing": [0, 0, 1], "up": [0, 1, 0]}],)"),
        "board");
    ASSERT_EQ(scene.tags.size(), 6u);
    // Seen from above with up = +y: the top-left tag is at -x, +y.
    EXPECT_EQ(scene.tags[0].id, 4);
    EXPECT_NEAR(scene.tags[0].placement.position.x, 1.8, 1e-12);
    EXPECT_NEAR(scene.tags[0].placement.position.y, 2.1, 1e-12);
    EXPECT_EQ(scene.tags[5].id, 9);
    EXPECT_NEAR(scene.tags[5].placement.position.x, 2.2, 1e-12);
    EXPECT_NEAR(scene.tags[5].placement.position.y, 1.9, 1e-12);
    EXPECT_NEAR(scene.tags[5].placement.position.z, 0.75, 1e-12);
}

TEST(SceneDescriptionTest, FaceFrameIsRightUpOutOfTheSurfaceLikeTrackingsTagFrame) {
    const Placement placement{{1.0, 2.0, 3.0}, {0.0, 0.0, 1.0}, {0.0, 1.0, 0.0}};
    const Pose world_T_face = placement.world_T_face();
    const glm::dvec3 x = world_T_face.transformDirection({1, 0, 0});
    const glm::dvec3 y = world_T_face.transformDirection({0, 1, 0});
    const glm::dvec3 z = world_T_face.transformDirection({0, 0, 1});
    EXPECT_NEAR(glm::length(x - glm::dvec3(1, 0, 0)), 0.0, 1e-12); // right, seen from above with +y up
    EXPECT_NEAR(glm::length(y - glm::dvec3(0, 1, 0)), 0.0, 1e-12); // up
    EXPECT_NEAR(glm::length(z - glm::dvec3(0, 0, 1)), 0.0, 1e-12); // out of the surface = facing
}

TEST(CameraPathTest, LookAtUsesTheOpenCvCameraFrame) {
    // Looking north (+y) from the origin: right is east (+x), down is -z.
    const Pose world_T_camera = lookAt({0, 0, 1}, {0, 5, 1});
    EXPECT_NEAR(glm::length(world_T_camera.transformDirection({1, 0, 0}) - glm::dvec3(1, 0, 0)), 0.0, 1e-12);
    EXPECT_NEAR(glm::length(world_T_camera.transformDirection({0, 1, 0}) - glm::dvec3(0, 0, -1)), 0.0, 1e-12);
    EXPECT_NEAR(glm::length(world_T_camera.transformDirection({0, 0, 1}) - glm::dvec3(0, 1, 0)), 0.0, 1e-12);
}

TEST(CameraPathTest, SegmentsFollowTheirGeometryAndChain) {
    const SceneDescription scene = parseSceneDescription(
        withPath(R"({"type": "orbit", "frames": 4, "center": [2, 2, 0.8], "radius": 1.5, "height": 1.4,
                     "startDegrees": 0, "endDegrees": 90},
                    {"type": "pan", "frames": 2, "position": [1, 1, 1.5], "startDegrees": 0, "endDegrees": 90},
                    {"type": "linear", "frames": 2, "from": {"position": [1, 1, 1], "target": [3, 1, 1]},
                                                    "to": {"position": [2, 1, 1], "target": [3, 1, 1]}})"),
        "path");
    ASSERT_EQ(scene.path.frameCount(), 8);
    // Orbit frame 2 of 4: t = 0.5, azimuth 45 degrees, looking at the centre.
    const Pose orbit = cameraPoseAt(scene.path, 2);
    const double c = std::cos(std::numbers::pi / 4.0) * 1.5;
    EXPECT_NEAR(glm::length(orbit.translation() - glm::dvec3(2 + c, 2 + c, 1.4)), 0.0, 1e-12);
    const glm::dvec3 forward = orbit.transformDirection({0, 0, 1});
    EXPECT_NEAR(glm::dot(forward, glm::normalize(glm::dvec3(2, 2, 0.8) - orbit.translation())), 1.0, 1e-12);
    // Pan frame 1 of 2: yaw 45 degrees, level.
    const glm::dvec3 pan = cameraPoseAt(scene.path, 5).transformDirection({0, 0, 1});
    EXPECT_NEAR(glm::length(pan - glm::normalize(glm::dvec3(1, 1, 0))), 0.0, 1e-12);
    // Linear frame 1 of 2: halfway.
    EXPECT_NEAR(glm::length(cameraPoseAt(scene.path, 7).translation() - glm::dvec3(1.5, 1, 1)), 0.0, 1e-12);
}

TEST(CameraPathTest, ShakeIsSeededSmoothAndHasTheRequestedSize) {
    CameraPathDescription path;
    PathSegment hold;
    hold.frames = 3000;
    hold.fromPosition = {1, 1, 1};
    hold.fromTarget = {2, 1, 1};
    path.segments.push_back(hold);
    path.shake = {0.01, 0.5, 42};
    const Pose still = lookAt(hold.fromPosition, hold.fromTarget);
    double sumSquares = 0.0, largestStep = 0.0;
    glm::dvec3 previous = cameraPoseAt(path, 0).translation();
    for (int i = 0; i < path.frameCount(); ++i) {
        const Pose pose = cameraPoseAt(path, i);
        const glm::dvec3 offset = pose.translation() - still.translation();
        sumSquares += glm::dot(offset, offset) / 3.0;
        largestStep = std::max(largestStep, glm::length(pose.translation() - previous));
        previous = pose.translation();
    }
    // 100 s of three incommensurate sinusoids per axis: the std is within 15 % of the request.
    EXPECT_NEAR(std::sqrt(sumSquares / path.frameCount()), 0.01, 0.0015);
    // Smooth: per axis at most sum_k 2 pi f_k a_k / fps <= 3 * 2 pi * 3 Hz * 0.01 sqrt(2/3) / 30
    // = 1.54 cm per frame, 2.67 cm in 3-D; white noise of the same std would jump further.
    EXPECT_LT(largestStep, 0.0267);
    // Seeded: the same seed repeats, another seed differs.
    const Pose a = cameraPoseAt(path, 17);
    EXPECT_EQ(a.translation(), cameraPoseAt(path, 17).translation());
    path.shake.seed = 43;
    EXPECT_GT(glm::length(cameraPoseAt(path, 17).translation() - a.translation()), 1e-6);
}

} // namespace
} // namespace lightskin::synth

namespace lightskin::synth {
namespace {

// The canonical scenes shipped in recordings/scenes-synth parse, and their paths do what the
// docs say: the pan sends the tag board out of the view and brings it back.
TEST(CanonicalScenesTest, ParseAndThePanLosesAndRegainsTheTags) {
    const std::filesystem::path folder = test::sourceDir() / "recordings" / "scenes-synth";
    for (const char* name : {"orbit.json", "pan.json", "clean-channels.json"}) {
        const SceneDescription scene = loadSceneDescription(folder / name);
        EXPECT_GE(scene.path.frameCount(), 4) << name;
        EXPECT_LE(scene.path.frameCount(), 60) << name;
        EXPECT_FALSE(scene.tags.empty()) << name;
    }
    const SceneDescription pan = loadSceneDescription(folder / "pan.json");
    const auto tagsInView = [&](int frame) {
        const Pose camera_T_world = cameraPoseAt(pan.path, frame).inverse();
        int inView = 0;
        for (const TagDescription& tag : pan.tags) {
            const glm::dvec3 p = camera_T_world.transformPoint(tag.placement.position);
            const glm::dvec2 pixel = pan.intrinsics.project(p);
            inView += p.z > 0 && pixel.x >= 0 && pixel.y >= 0 && pixel.x < pan.intrinsics.width && pixel.y < pan.intrinsics.height;
        }
        return inView;
    };
    std::string states;
    for (int frame = 0; frame < pan.path.frameCount(); ++frame) states += tagsInView(frame) == 4 ? 'T' : tagsInView(frame) == 0 ? '.' : 'p';
    std::printf("pan: tags in view per frame (T all, p some, . none): %s\n", states.c_str());
    EXPECT_EQ(states.front(), 'T');
    EXPECT_EQ(states.back(), 'T');
    EXPECT_GE(std::count(states.begin(), states.end(), '.'), 8);
}

} // namespace
} // namespace lightskin::synth
