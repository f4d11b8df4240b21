// The synthetic recording through the rest of lightskin: capture's reader gives back exactly what
// the generator rendered, and tracking's AprilTag detector finds the real tag36h11 patterns with
// the right ids and corners where the ground-truth pose puts them.
#include "GlTestEnvironment.h"
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/synth/Generator.h>
#include <lightskin/synth/SynthRecording.h>
#include <lightskin/tracking/TagDetector.h>
#include <lightskin/tracking/TagWorld.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <set>

namespace lightskin::synth {
namespace {

using SynthRecordingGLTest = test::GlTest;

const std::string roomWithTags = R"({
  "format": "lightskin-synth-scene", "version": 1, "name": "roundtrip",
  "room": {"west": [0.75, 0.08, 0.06], "east": [0.08, 0.6, 0.1]},
  "boxes": [{"name": "table", "center": [2.0, 1.75, 0.375], "size": [1.2, 0.8, 0.75], "albedo": [0.55, 0.4, 0.25]}],
  "lights": [{"type": "point", "position": [2.0, 1.6, 2.3], "powerWatts": 60}],
  "ambientRadiance": 0.05,
  "tagBoards": [{"firstId": 0, "rows": 2, "columns": 2, "size": 0.12, "spacing": 0.16,
                 "position": [2.0, 1.75, 0.75], "facing": [0, 0, 1], "up": [0, 1, 0]}],
  "tags": [{"id": 10, "size": 0.2, "position": [2.0, 3.5, 1.3], "facing": [0, -1, 0], "up": [0, 0, 1]}],
  "render": {"exposure": 1.5, "supersampling": 3},
  "noise": {"seed": 4},
  "outputs": {"normals": true, "positions": true, "radiance": true},
  "camera": {"width": WIDTH, "height": HEIGHT},
  "path": {"segments": [{"type": "orbit", "frames": FRAMES, "center": [2.0, 1.75, 0.75], "target": [2.0, 2.1, 0.85],
                         "radius": 1.3, "height": 1.5, "startDegrees": 250, "endDegrees": 290}],
           "shake": {"translationStdMetres": 0.003, "rotationStdDegrees": 0.2}}
})";

std::string sceneText(int width, int height, int frames) {
    std::string text = roomWithTags;
    text.replace(text.find("WIDTH"), 5, std::to_string(width));
    text.replace(text.find("HEIGHT"), 6, std::to_string(height));
    text.replace(text.find("FRAMES"), 6, std::to_string(frames));
    return text;
}

TEST_F(SynthRecordingGLTest, RecordingRoundTripsThroughTheCaptureReader) {
    const std::string text = sceneText(96, 72, 3);
    const SceneDescription scene = parseSceneDescription(text, "roundtrip.json");
    const std::filesystem::path folder = test::scratchDir("synth-roundtrip") / "recording";
    EXPECT_EQ(writeSynthRecording(scene, text, folder), 3);

    Generator generator = Generator::create(scene);
    const std::vector<SynthFrame> expected = generator.renderAll();
    auto source = capture::openFrameSource(folder.string());
    EXPECT_EQ(source->info().kind, "lightskin-recording");
    EXPECT_TRUE(source->info().hasGroundTruth);
    EXPECT_EQ(source->frameCount(), std::optional<std::int64_t>(3));
    RgbdFrame frame;
    std::size_t count = 0;
    while (source->next(frame)) {
        ASSERT_LT(count, expected.size());
        const RgbdFrame& original = expected[count].frame;
        EXPECT_EQ(frame.index, std::int64_t(count));
        EXPECT_EQ(cv::norm(frame.depth, original.depth, cv::NORM_INF), 0.0); // 16-bit PNG: bit-exact
        EXPECT_EQ(cv::norm(frame.colour, original.colour, cv::NORM_INF), 0.0); // lossless PNG
        EXPECT_EQ(frame.depthScaleMetres, 0.001);
        EXPECT_EQ(frame.colourIntrinsics.describe(), scene.intrinsics.describe());
        ASSERT_TRUE(frame.groundTruth_world_T_camera.has_value());
        EXPECT_LT(Pose::translationDistance(*frame.groundTruth_world_T_camera, *original.groundTruth_world_T_camera), 1e-9);
        EXPECT_LT(Pose::rotationAngleBetween(*frame.groundTruth_world_T_camera, *original.groundTruth_world_T_camera), 1e-9);
        EXPECT_NEAR(frame.depthTimestampSeconds, double(count) / 30.0, 1e-9);

        char name[32];
        std::snprintf(name, sizeof name, "%06zu.tiff", count);
        EXPECT_EQ(cv::norm(readSynthChannel(folder / "synth" / "normals" / name), expected[count].exact.worldNormal, cv::NORM_INF), 0.0);
        EXPECT_EQ(cv::norm(readSynthChannel(folder / "synth" / "positions" / name), expected[count].exact.worldPosition, cv::NORM_INF), 0.0);
        EXPECT_EQ(cv::norm(readSynthChannel(folder / "synth" / "radiance" / name), expected[count].exact.radiance, cv::NORM_INF), 0.0);
        ++count;
    }
    EXPECT_EQ(count, 3u);

    // The tag world file loads in tracking and holds the five tags at their described poses.
    const tracking::TagWorld world = tracking::TagWorld::load(folder / "synth" / "tag-world.json");
    ASSERT_EQ(world.tags().size(), 5u);
    const tracking::WorldTag* wallTag = world.find(10);
    ASSERT_NE(wallTag, nullptr);
    EXPECT_NEAR(glm::length(wallTag->world_T_tag.translation() - glm::dvec3(2.0, 3.5, 1.3)), 0.0, 1e-12);
    // Its z axis points out of the wall, into the room (-y).
    EXPECT_NEAR(glm::length(wallTag->world_T_tag.transformDirection({0, 0, 1}) - glm::dvec3(0, -1, 0)), 0.0, 1e-12);
}

// libapriltag (through tracking) decodes the rendered tags: right ids, and its corners (in its
// order: tag frame (-s/2,-s/2), (s/2,-s/2), (s/2,s/2), (-s/2,s/2)) within 0.5 px of the
// ground-truth reprojection, which also proves the bitmaps are not rotated or mirrored.
TEST_F(SynthRecordingGLTest, AprilTagDetectorFindsTheRealTagsWhereTheGroundTruthPutsThem) {
    const std::string text = sceneText(640, 480, 2);
    SceneDescription scene = parseSceneDescription(text, "tags.json");
    scene.noise.enabled = false;
    Generator generator = Generator::create(scene);
    tracking::DetectorSettings settings;
    settings.quadDecimate = 1.0f; // the board's tags are ~40 px
    tracking::TagDetector detector = tracking::TagDetector::create(settings);
    SynthFrame frame;
    std::vector<glm::dvec2> differences; // detected - ground truth, per corner
    for (int index = 0; index < generator.frameCount(); ++index) {
        generator.renderFrameInto(index, frame);
        const Pose camera_T_world = frame.frame.groundTruth_world_T_camera->inverse();
        std::set<int> found;
        for (const tracking::TagDetection& detection : detector.detect(frame.frame.colour)) {
            found.insert(detection.id);
            const auto tag = std::find_if(scene.tags.begin(), scene.tags.end(), [&](const TagDescription& t) { return t.id == detection.id; });
            ASSERT_NE(tag, scene.tags.end()) << "detected an id that is not in the scene: " << detection.id;
            const Pose world_T_tag = tag->placement.world_T_face();
            const double h = tag->sizeMetres / 2.0;
            const glm::dvec3 tagCorners[4] = {{-h, -h, 0}, {h, -h, 0}, {h, h, 0}, {-h, h, 0}};
            for (int c = 0; c < 4; ++c) {
                const glm::dvec2 expected = scene.intrinsics.project(camera_T_world.transformPoint(world_T_tag.transformPoint(tagCorners[c])));
                differences.push_back(detection.corners[std::size_t(c)] - expected);
            }
        }
        EXPECT_EQ(found, (std::set<int>{0, 1, 2, 3, 10})) << "frame " << index;
    }
    ASSERT_FALSE(differences.empty());
    // tracking reports corners in OpenCV's pixel convention (it removes libapriltag's +0.5 px
    // pixel-centre offset), like the renderer: no common shift beyond 0.15 px. Each corner within
    // 0.75 px: the detector's own accuracy on ~40 px tags (the renderer's corners are checked to
    // 0.5 px, measured 0.16 px, by the edge fit in SceneRendererGLTest). A rotated or mirrored
    // bitmap would be off by a whole tag edge (~40 px).
    glm::dvec2 mean(0.0);
    double worst = 0.0;
    for (const glm::dvec2& d : differences) {
        mean += d;
        worst = std::max(worst, glm::length(d));
    }
    mean /= double(differences.size());
    std::printf("apriltag: %zu corners, mean offset detector - ground truth (%+.3f, %+.3f) px, worst %.3f px\n",
                differences.size(), mean.x, mean.y, worst);
    EXPECT_LT(glm::length(mean), 0.15);
    EXPECT_LT(worst, 0.75);
}

} // namespace
} // namespace lightskin::synth

namespace lightskin::synth {
namespace {

// The shipped canonical recordings are what their descriptions make: poses to 1e-9, and for the
// noise-free one, depth bit for bit and colour within one 8-bit step (GL implementations may
// round the last bit differently), frame 0 re-rendered here.
TEST_F(SynthRecordingGLTest, ShippedRecordingsMatchTheirDescriptions) {
    const std::filesystem::path recordings = test::sourceDir() / "recordings";
    for (const auto& [description, folder] : {std::pair{"orbit.json", "synth-orbit"}, std::pair{"pan.json", "synth-pan"},
                                              std::pair{"clean-channels.json", "synth-clean-channels"}}) {
        const SceneDescription scene = loadSceneDescription(recordings / "scenes-synth" / description);
        auto source = capture::openFrameSource((recordings / folder).string());
        ASSERT_EQ(source->frameCount(), std::optional<std::int64_t>(scene.path.frameCount())) << folder;
        RgbdFrame frame;
        int index = 0;
        while (source->next(frame)) {
            ASSERT_TRUE(frame.groundTruth_world_T_camera.has_value());
            const Pose expected = cameraPoseAt(scene.path, index);
            EXPECT_LT(Pose::translationDistance(*frame.groundTruth_world_T_camera, expected), 1e-9) << folder << " " << index;
            EXPECT_LT(Pose::rotationAngleBetween(*frame.groundTruth_world_T_camera, expected), 1e-9) << folder << " " << index;
            ++index;
        }
        EXPECT_EQ(index, scene.path.frameCount());
    }
    const SceneDescription clean = loadSceneDescription(recordings / "scenes-synth" / "clean-channels.json");
    Generator generator = Generator::create(clean);
    SynthFrame rendered;
    generator.renderFrameInto(0, rendered);
    auto source = capture::openFrameSource((recordings / "synth-clean-channels").string());
    RgbdFrame shipped;
    ASSERT_TRUE(source->next(shipped));
    EXPECT_EQ(cv::norm(shipped.depth, rendered.frame.depth, cv::NORM_INF), 0.0);
    EXPECT_LE(cv::norm(shipped.colour, rendered.frame.colour, cv::NORM_INF), 1.0);
    EXPECT_LT(cv::norm(readSynthChannel(recordings / "synth-clean-channels" / "synth" / "positions" / "000000.tiff"),
                       rendered.exact.worldPosition, cv::NORM_INF), 1e-5);
}

} // namespace
} // namespace lightskin::synth
