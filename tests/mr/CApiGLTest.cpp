// The C ABI (liblightskin.so through lightskin.h) in process: versions, argument and input errors
// with thread-local messages, versioned structs (an older, shorter struct is not written past its
// size), and a host-submitted frame whose pose comes back in the report.
#include "GlTestEnvironment.h"
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>

#include <glm/gtc/type_ptr.hpp>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cstddef>
#include <cstring>
#include <fstream>
#include <lightskin.h>
#include <limits>
#include <string>
#include <thread>
#include <vector>

namespace {

std::filesystem::path sourceDir() { return lightskin::test::sourceDir(); }

lsk_scene orbitScene(const std::string& path) {
    lsk_scene scene;
    lsk_scene_init(&scene);
    scene.path = path.c_str();
    return scene;
}

class CApiGLTest : public lightskin::test::GlTest {};

/// A recording's frame as the host submits it, with its ground-truth pose; `rgb` keeps the pixels it points to.
lsk_frame hostFrame(const lightskin::RgbdFrame& frame, const lsk_camera& camera, cv::Mat& rgb) {
    cv::cvtColor(frame.colour, rgb, cv::COLOR_BGR2RGB);
    lsk_frame f;
    lsk_frame_init(&f);
    f.rgb = rgb.data;
    f.depth = frame.depth.ptr<std::uint16_t>();
    f.depth_scale_metres = frame.depthScaleMetres;
    f.camera = camera;
    f.has_pose = 1;
    const glm::dmat4 pose = frame.groundTruth_world_T_camera->matrix();
    std::memcpy(f.world_T_camera, glm::value_ptr(pose), sizeof f.world_T_camera);
    return f;
}

TEST_F(CApiGLTest, VersionMatchesTheHeader) {
    EXPECT_EQ(std::string(lsk_version()), std::to_string(LSK_VERSION_MAJOR) + "." + std::to_string(LSK_VERSION_MINOR) +
                                              "." + std::to_string(LSK_VERSION_PATCH));
}

TEST_F(CApiGLTest, BadArgumentsAndInputAreErrorCodesWithMessages) {
    lsk_session* session = reinterpret_cast<lsk_session*>(0x1);
    const std::string scenePath = (sourceDir() / "recordings/scenes/orbit.json").string();
    lsk_scene scene = orbitScene(scenePath);
    EXPECT_EQ(lsk_session_create_from_source(nullptr, &scene, nullptr, &session), LSK_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(lsk_last_error()), "");
    // A struct whose size was never set is refused, not read.
    lsk_scene unset{};
    EXPECT_EQ(lsk_session_create_from_source(nullptr, &unset, "x", &session), LSK_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(lsk_last_error()).find("struct_size"), std::string::npos) << lsk_last_error();
    // A missing scene file: an input error naming the file; no session.
    const std::string missing = "/nonexistent/scene-for-capi.json";
    lsk_scene bad = orbitScene(missing);
    EXPECT_EQ(lsk_session_create_from_source(nullptr, &bad, (sourceDir() / "recordings/synth-orbit").c_str(), &session),
              LSK_ERROR_INPUT);
    EXPECT_EQ(session, nullptr);
    EXPECT_NE(std::string(lsk_last_error()).find(missing), std::string::npos) << lsk_last_error();
    lsk_session_options options;
    lsk_session_options_init(&options);
    options.pose_mode = 7;
    EXPECT_EQ(lsk_session_create_from_source(&options, &scene, "x", &session), LSK_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(lsk_last_error()).find("pose_mode"), std::string::npos) << lsk_last_error();
    lsk_session_destroy(nullptr); // ignored
}

TEST_F(CApiGLTest, LastErrorIsPerThread) {
    EXPECT_EQ(lsk_session_process_next(nullptr), LSK_ERROR_INVALID_ARGUMENT);
    const std::string mine = lsk_last_error();
    ASSERT_NE(mine, "");
    std::string other = "unset";
    std::thread([&other] { other = lsk_last_error(); }).join();
    EXPECT_EQ(other, "") << "another thread saw this thread's error";
    EXPECT_EQ(std::string(lsk_last_error()), mine);
    EXPECT_EQ(lsk_session_set_budget(nullptr, 1.0), LSK_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(lsk_last_error()), mine) << "a new error replaces the old one";
}

TEST_F(CApiGLTest, HostFrameRoundTripAndVersionedReport) {
    auto source = lightskin::capture::openFrameSource(sourceDir() / "recordings/synth-orbit", {});
    lightskin::RgbdFrame frame;
    ASSERT_TRUE(source->next(frame));
    ASSERT_TRUE(frame.groundTruth_world_T_camera.has_value());
    const lightskin::CameraIntrinsics& k = frame.colourIntrinsics;
    const lsk_camera camera{k.width, k.height, k.fx, k.fy, k.cx, k.cy};
    const std::string scenePath = (sourceDir() / "recordings/scenes/orbit.json").string();
    // The scene as JSON text, with the differential composite off: this test checks that only
    // covered pixels change (the differential also changes real pixels around the objects, by design).
    // On the GL backend whatever the renderer (gi.backend "auto" would take the CPU on llvmpipe).
    std::string text = lightskin::test::readText(scenePath);
    const std::string key = "\"compositing\": {";
    const auto at = text.find(key);
    ASSERT_NE(at, std::string::npos) << scenePath;
    text.insert(at + key.size(), "\"differential\": false, ");
    const std::string gi = "\"gi\": {";
    const auto giAt = text.find(gi);
    ASSERT_NE(giAt, std::string::npos) << scenePath;
    text.insert(giAt + gi.size(), "\"backend\": \"gl\", ");
    const std::string base = (sourceDir() / "recordings/scenes").string();
    lsk_scene scene;
    lsk_scene_init(&scene);
    scene.json = text.c_str();
    scene.base_folder = base.c_str();
    lsk_session* session = nullptr;
    ASSERT_EQ(lsk_session_create(nullptr, &scene, &camera, &session), LSK_OK) << lsk_last_error();
    ASSERT_NE(session, nullptr);

    cv::Mat rgb;
    lsk_frame f = hostFrame(frame, camera, rgb);
    f.timestamp_seconds = 3.25;
    ASSERT_EQ(lsk_session_submit(session, &f), LSK_OK) << lsk_last_error();

    lsk_frame_report report;
    lsk_frame_report_init(&report);
    ASSERT_EQ(lsk_session_report(session, &report), LSK_OK);
    EXPECT_EQ(report.frame_index, 0);
    EXPECT_EQ(report.timestamp_seconds, 3.25);
    EXPECT_EQ(report.tracking_state, LSK_TRACKING);
    ASSERT_EQ(report.has_pose, 1);
    for (int i = 0; i < 16; ++i) EXPECT_NEAR(report.world_T_camera[i], f.world_T_camera[i], 1e-12) << i;
    EXPECT_GT(report.val_count, 0u);
    EXPECT_GT(report.covered_pixels, 0);
    ASSERT_GE(report.stage_count, 4u);
    EXPECT_STREQ(report.stages[0].name, "depth filter");
    EXPECT_EQ(report.technique, LSK_TECHNIQUE_LIGHTSKIN);
    std::int32_t technique = -1, backend = -1;
    ASSERT_EQ(lsk_session_technique(session, &technique, &backend), LSK_OK) << lsk_last_error();
    EXPECT_EQ(technique, LSK_TECHNIQUE_LIGHTSKIN);
    EXPECT_EQ(backend, LSK_BACKEND_GL);
    EXPECT_EQ(lsk_session_technique(nullptr, &technique, nullptr), LSK_ERROR_INVALID_ARGUMENT);

    // The composite in host memory: the camera image bit for bit wherever no virtual content is
    // (render/Compositor.h: a == 0 copies the camera pixel), something else where it is.
    std::vector<std::uint8_t> composite(std::size_t(k.width) * std::size_t(k.height) * 3);
    ASSERT_EQ(lsk_session_read_composite(session, composite.data(), 0), LSK_OK) << lsk_last_error();
    const cv::Mat compositeRgb(k.height, k.width, CV_8UC3, composite.data());
    cv::Mat difference, changed;
    cv::absdiff(compositeRgb, rgb, difference);
    cv::cvtColor(difference, changed, cv::COLOR_RGB2GRAY);
    const int changedPixels = cv::countNonZero(changed);
    EXPECT_GT(changedPixels, 0);
    EXPECT_LE(changedPixels, report.covered_pixels);

    // An older host's report ends before the stage list: nothing past its size is written.
    constexpr std::size_t kOldSize = offsetof(lsk_frame_report, stage_count);
    unsigned char buffer[sizeof(lsk_frame_report)];
    std::memset(buffer, 0xAB, sizeof buffer);
    lsk_frame_report old;
    std::memset(&old, 0, sizeof old);
    old.struct_size = kOldSize;
    std::memcpy(buffer, &old, sizeof old.struct_size);
    ASSERT_EQ(lsk_session_report(session, reinterpret_cast<lsk_frame_report*>(buffer)), LSK_OK);
    for (std::size_t i = kOldSize; i < sizeof buffer; ++i) ASSERT_EQ(buffer[i], 0xAB) << "byte " << i << " written";
    lsk_frame_report shortened;
    std::memcpy(&shortened, buffer, kOldSize);
    EXPECT_EQ(shortened.struct_size, kOldSize);
    EXPECT_EQ(shortened.val_count, report.val_count);

    // Wrong camera: an input error naming the intrinsics.
    f.camera.fx += 1.0;
    EXPECT_EQ(lsk_session_submit(session, &f), LSK_ERROR_INPUT);
    EXPECT_NE(std::string(lsk_last_error()).find("intrinsics"), std::string::npos) << lsk_last_error();
    lsk_render_target target;
    lsk_render_target_init(&target);
    target.content = 9;
    EXPECT_EQ(lsk_session_render(session, &target), LSK_ERROR_INVALID_ARGUMENT);
    lsk_session_destroy(session);
}

// A scene without virtual objects is valid: the real room composited alone (the camera image bit for
// bit), GI idle, for every technique.
TEST_F(CApiGLTest, ASceneWithoutObjectsShowsTheRoomAlone) {
    auto source = lightskin::capture::openFrameSource(sourceDir() / "recordings/synth-orbit", {});
    lightskin::RgbdFrame frame;
    ASSERT_TRUE(source->next(frame));
    const lightskin::CameraIntrinsics& k = frame.colourIntrinsics;
    const lsk_camera camera{k.width, k.height, k.fx, k.fy, k.cx, k.cy};
    cv::Mat rgb;
    for (const std::string technique : {"lightskin", "brute-force", "imperfect-volumes", "multiscale-prt", "none"}) {
        for (const std::string objects : {"\"objects\": [], ", ""}) {
            SCOPED_TRACE(technique + (objects.empty() ? ", no objects key" : ", objects []"));
            const std::string text = "{\"version\": 1, " + objects +
                                     "\"lights\": [{\"type\": \"point\", \"position\": [2, 1.6, 2.3], \"power\": 60}], "
                                     "\"gi\": {\"technique\": \"" +
                                     technique + "\"}}";
            lsk_scene scene;
            lsk_scene_init(&scene);
            scene.json = text.c_str();
            lsk_session* session = nullptr;
            ASSERT_EQ(lsk_session_create(nullptr, &scene, &camera, &session), LSK_OK) << lsk_last_error();
            const lsk_frame f = hostFrame(frame, camera, rgb);
            ASSERT_EQ(lsk_session_submit(session, &f), LSK_OK) << lsk_last_error();
            lsk_frame_report report;
            lsk_frame_report_init(&report);
            ASSERT_EQ(lsk_session_report(session, &report), LSK_OK);
            EXPECT_EQ(report.covered_pixels, 0);
            std::vector<std::uint8_t> composite(std::size_t(k.width) * std::size_t(k.height) * 3);
            ASSERT_EQ(lsk_session_read_composite(session, composite.data(), 0), LSK_OK) << lsk_last_error();
            cv::Mat difference, changed;
            cv::absdiff(cv::Mat(k.height, k.width, CV_8UC3, composite.data()), rgb, difference);
            cv::cvtColor(difference, changed, cv::COLOR_RGB2GRAY);
            EXPECT_EQ(cv::countNonZero(changed), 0);
            lsk_session_destroy(session);
        }
    }
}

// Moving content through the C ABI: counts and names, a move that shows in the next frame's composite, and bad
// input that returns an error naming the object or light and leaves the session as it was.
TEST_F(CApiGLTest, HostMovesAddsAndRemovesObjectsAndBadInputIsAnError) {
    auto source = lightskin::capture::openFrameSource(sourceDir() / "recordings/synth-orbit", {});
    lightskin::RgbdFrame frame;
    ASSERT_TRUE(source->next(frame));
    const lightskin::CameraIntrinsics& k = frame.colourIntrinsics;
    const lsk_camera camera{k.width, k.height, k.fx, k.fy, k.cx, k.cy};
    const std::string scenePath = (sourceDir() / "recordings/scenes/orbit.json").string();
    lsk_scene scene = orbitScene(scenePath);
    lsk_session* session = nullptr;
    ASSERT_EQ(lsk_session_create(nullptr, &scene, &camera, &session), LSK_OK) << lsk_last_error();
    cv::Mat rgb;
    const lsk_frame f = hostFrame(frame, camera, rgb);
    const auto composite = [&] {
        EXPECT_EQ(lsk_session_submit(session, &f), LSK_OK) << lsk_last_error();
        std::vector<std::uint8_t> image(std::size_t(k.width) * std::size_t(k.height) * 3);
        EXPECT_EQ(lsk_session_read_composite(session, image.data(), 0), LSK_OK) << lsk_last_error();
        return image;
    };
    const std::vector<std::uint8_t> original = composite();

    uint32_t objects = 0, lights = 0;
    ASSERT_EQ(lsk_session_object_count(session, &objects), LSK_OK);
    ASSERT_EQ(lsk_session_light_count(session, &lights), LSK_OK);
    EXPECT_EQ(objects, 2u);
    EXPECT_EQ(lights, 1u);
    const char* name = nullptr;
    ASSERT_EQ(lsk_session_object_name(session, 1, &name), LSK_OK);
    EXPECT_STREQ(name, "cube");

    const auto expectError = [&](lsk_status status, lsk_status expected, const std::string& mention) {
        EXPECT_EQ(status, expected);
        EXPECT_NE(std::string(lsk_last_error()).find(mention), std::string::npos) << lsk_last_error();
    };
    const float nan = std::numeric_limits<float>::quiet_NaN();
    float matrix[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 2.3f, 1.6f, 0.81f, 1};
    expectError(lsk_session_object_name(session, 2, &name), LSK_ERROR_INVALID_ARGUMENT, "object 2");
    expectError(lsk_session_set_object_transform(session, 7, matrix), LSK_ERROR_INPUT, "object 7: no such object");
    float bad[16];
    std::memcpy(bad, matrix, sizeof bad);
    bad[5] = nan;
    expectError(lsk_session_set_object_transform(session, 1, bad), LSK_ERROR_INPUT,
                "object 1: the transform has a non-finite");
    bad[5] = 0.0f; // a zero scale along y: singular
    expectError(lsk_session_set_object_transform(session, 1, bad), LSK_ERROR_INPUT,
                "object 1: the transform is singular");
    expectError(lsk_session_set_object_transform(session, 1, nullptr), LSK_ERROR_INVALID_ARGUMENT, "world_T_model");
    const float position[3] = {2.0f, 1.6f, 2.3f}, negative[3] = {-1.0f, 60.0f, 60.0f};
    expectError(lsk_session_set_light(session, 0, position, nullptr, negative), LSK_ERROR_INPUT, "light 0: the power");
    expectError(lsk_session_set_light(session, 3, position, nullptr, negative), LSK_ERROR_INPUT,
                "light 3: no such light");
    expectError(lsk_session_set_object_visible(session, 0, 2), LSK_ERROR_INVALID_ARGUMENT, "visible");
    lsk_material unset{};
    expectError(lsk_session_set_object_material(session, 0, &unset), LSK_ERROR_INVALID_ARGUMENT, "struct_size");
    expectError(lsk_session_add_object(session, "/nonexistent/mesh.obj", "ghost", nullptr, nullptr), LSK_ERROR_INPUT,
                "/nonexistent/mesh.obj");
    expectError(lsk_session_add_object(session, scenePath.c_str(), "", nullptr, nullptr), LSK_ERROR_INVALID_ARGUMENT,
                "name");
    expectError(lsk_session_remove_object(session, 2), LSK_ERROR_INPUT, "object 2");
    ASSERT_EQ(lsk_session_object_count(session, &objects), LSK_OK);
    EXPECT_EQ(objects, 2u);
    // Values that differ by more than one code: the GL backend's runs differ by at most one (VAL order).
    const auto differing = [](const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
        std::size_t n = 0;
        for (std::size_t i = 0; i < a.size(); ++i) n += std::abs(int(a[i]) - int(b[i])) > 1 ? 1u : 0u;
        return n;
    };
    EXPECT_EQ(differing(composite(), original), 0u) << "an error changed the content";

    // A move shows; an added object shows and is counted; removing it restores the image.
    ASSERT_EQ(lsk_session_set_object_transform(session, 1, matrix), LSK_OK) << lsk_last_error();
    const std::vector<std::uint8_t> moved = composite();
    EXPECT_GT(differing(moved, original), 500u);
    lsk_material red;
    lsk_material_init(&red);
    red.set_diffuse = 1;
    red.diffuse_albedo[0] = 0.8f;
    red.diffuse_albedo[1] = red.diffuse_albedo[2] = 0.1f;
    ASSERT_EQ(lsk_session_set_object_material(session, 1, &red), LSK_OK) << lsk_last_error();
    const std::string cube = (sourceDir() / "recordings/scenes/meshes/cube.obj").string();
    float placement[16] = {0.1f, 0, 0, 0, 0, 0.1f, 0, 0, 0, 0, 0.1f, 0, 1.8f, 1.7f, 0.80f, 1};
    uint32_t added = 0;
    ASSERT_EQ(lsk_session_add_object(session, cube.c_str(), "second cube", placement, &added), LSK_OK)
        << lsk_last_error();
    EXPECT_EQ(added, 2u);
    ASSERT_EQ(lsk_session_object_count(session, &objects), LSK_OK);
    EXPECT_EQ(objects, 3u);
    const std::vector<std::uint8_t> withThird = composite();
    ASSERT_EQ(lsk_session_remove_object(session, 2), LSK_OK) << lsk_last_error();
    const std::vector<std::uint8_t> withoutThird = composite();
    EXPECT_GT(differing(withThird, withoutThird), 200u) << "the added cube was seen";
    lsk_session_destroy(session);
}

} // namespace

// The room memory through the C ABI: a source-fed session with tag tracking saves its model, a second one loads it;
// bad paths and a session without room memory are errors with messages (the format itself:
// tests/roommodel/RoomModelFileTest.cpp).
TEST_F(CApiGLTest, RoomModelIsSavedAndLoadedAndBadInputIsAnError) {
    const std::filesystem::path scratch = lightskin::test::scratchDir("capi_room_model");
    const std::string scenePath = (sourceDir() / "recordings/scenes/orbit.json").string();
    const std::string recording = (sourceDir() / "recordings/synth-orbit").string();
    const std::string file = (scratch / "room.lsroom").string();
    lsk_session_options options;
    lsk_session_options_init(&options);
    options.pose_mode = LSK_POSE_TRACKING;
    const lsk_scene scene = orbitScene(scenePath);
    lsk_session* first = nullptr;
    ASSERT_EQ(lsk_session_create_from_source(&options, &scene, recording.c_str(), &first), LSK_OK) << lsk_last_error();
    for (int i = 0; i < 4; ++i) ASSERT_EQ(lsk_session_process_next(first), LSK_OK) << lsk_last_error();
    EXPECT_EQ(lsk_session_save_room_model(first, nullptr), LSK_ERROR_INVALID_ARGUMENT);
    ASSERT_EQ(lsk_session_save_room_model(first, file.c_str()), LSK_OK) << lsk_last_error();
    lsk_session_destroy(first);
    EXPECT_TRUE(std::filesystem::file_size(file) > 0);

    lsk_session* second = nullptr;
    ASSERT_EQ(lsk_session_create_from_source(&options, &scene, recording.c_str(), &second), LSK_OK);
    EXPECT_EQ(lsk_session_load_room_model(second, file.c_str()), LSK_OK) << lsk_last_error();
    const std::string notes = (scratch / "notes.txt").string();
    std::ofstream(notes) << "not a room model\n";
    EXPECT_NE(lsk_session_load_room_model(second, notes.c_str()), LSK_OK);
    EXPECT_NE(std::string(lsk_last_error()).find(notes), std::string::npos) << lsk_last_error();
    EXPECT_EQ(lsk_session_process_next(second), LSK_OK) << lsk_last_error(); // the session goes on
    lsk_session_destroy(second);

    lsk_session_options host;
    lsk_session_options_init(&host); // LSK_POSE_HOST: no room memory
    lsk_session* withoutMemory = nullptr;
    ASSERT_EQ(lsk_session_create_from_source(&host, &scene, recording.c_str(), &withoutMemory), LSK_OK);
    EXPECT_NE(lsk_session_save_room_model(withoutMemory, (scratch / "none.lsroom").c_str()), LSK_OK);
    EXPECT_NE(std::string(lsk_last_error()).find("room memory"), std::string::npos) << lsk_last_error();
    EXPECT_FALSE(std::filesystem::exists(scratch / "none.lsroom"));
    lsk_session_destroy(withoutMemory);
}
