// `lightskin live` without hardware: .oni input, headless (EGL) and in a real GLFW window under Xvfb.
#include "TestPaths.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdlib>
#include <fstream>
#include <sys/wait.h>

namespace fs = std::filesystem;
using namespace lightskin;

namespace {

const std::string kCubeScene = R"({"version": 1,
 "objects": [{"mesh": "cube.obj", "transform": {"translation": [0, 0, 1.2], "rotationDegrees": [20, 30, 0], "scale": 0.3},
              "material": {"diffuseAlbedo": [0.8, 0.3, 0.2]}}],
 "lights": [{"type": "point", "position": [0.5, -0.5, 0.0], "power": 40}],
 "gi": {"technique": "lightskin", "sparsePoints": 64},
 "compositing": {"differential": false}})"; // placement only: the differential changes real pixels too
const std::string kEmptyScene = R"({"version": 1, "gi": {"technique": "none"}})";

fs::path writeScene(const fs::path& folder, const std::string& name, const std::string& text) {
    fs::copy_file(test::sourceDir() / "recordings" / "scenes" / "meshes" / "cube.obj", folder / "cube.obj",
                  fs::copy_options::overwrite_existing);
    std::ofstream(folder / name) << text;
    return folder / name;
}

int run(const std::string& prefix, const std::string& arguments, const fs::path& scratch) {
    const std::string command = prefix + std::string(LIGHTSKIN_PROGRAM) + " " + arguments + " > " +
                                (scratch / "stdout.txt").string() + " 2> " + (scratch / "stderr.txt").string();
    return test::runShell(command);
}

std::string liveArguments(const fs::path& scene, const fs::path& snapshot) {
    // Manual stepping of the .oni, identity pose (world = camera frame), snapshot of frame 1.
    return "live --device " + test::dataPath("oni-kinect-v1/3dj_test.oni").string() + " --scene " + scene.string() +
           " --pose fixed --fast --max-frames 3 --snapshot-after 1 --snapshot " + snapshot.string();
}

std::string stderrOf(const fs::path& scratch) {
    std::ifstream file(scratch / "stderr.txt");
    return {std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
}

} // namespace

TEST(LiveCommand, HeadlessFromOniShowsTheCubeAndLeavesTheRestOfTheFrame) {
    const fs::path scratch = test::scratchDir("live_headless");
    const fs::path withCube = scratch / "cube.png", empty = scratch / "empty.png";
    ASSERT_EQ(run("", liveArguments(writeScene(scratch, "cube.json", kCubeScene), withCube) + " --headless", scratch),
              0)
        << stderrOf(scratch);
    ASSERT_EQ(run("", liveArguments(writeScene(scratch, "empty.json", kEmptyScene), empty) + " --headless", scratch), 0)
        << stderrOf(scratch);
    const cv::Mat a = cv::imread(withCube.string(), cv::IMREAD_COLOR), b = cv::imread(empty.string(), cv::IMREAD_COLOR);
    ASSERT_EQ(a.size(), cv::Size(640, 480));
    ASSERT_EQ(b.size(), a.size());
    // The cube sits on the optical axis at 1.2 m: the image centre changes; the top band (no
    // virtual content, above the status line) is the camera frame, bit for bit.
    EXPECT_GT(cv::norm(a(cv::Rect(300, 220, 40, 40)), b(cv::Rect(300, 220, 40, 40)), cv::NORM_L1), 40.0 * 40.0 * 10.0);
    EXPECT_EQ(cv::norm(a(cv::Rect(0, 0, 640, 60)), b(cv::Rect(0, 0, 640, 60)), cv::NORM_INF), 0.0);
}

TEST(LiveCommand, RealWindowUnderXvfbShowsWhatHeadlessRenders) {
    if (std::system("command -v xvfb-run > /dev/null 2>&1") != 0) GTEST_SKIP() << "xvfb-run is not installed";
    const fs::path scratch = test::scratchDir("live_window");
    const fs::path scene = writeScene(scratch, "cube.json", kCubeScene);
    const fs::path window = scratch / "window.png", headless = scratch / "headless.png";
    ASSERT_EQ(run("xvfb-run -a -s '-screen 0 1024x768x24' ", liveArguments(scene, window), scratch), 0)
        << stderrOf(scratch);
    ASSERT_EQ(run("", liveArguments(scene, headless) + " --headless", scratch), 0) << stderrOf(scratch);
    const cv::Mat a = cv::imread(window.string(), cv::IMREAD_COLOR),
                  b = cv::imread(headless.string(), cv::IMREAD_COLOR);
    ASSERT_EQ(a.size(), cv::Size(640, 480)); // read back from the window's framebuffer
    ASSERT_EQ(b.size(), a.size());
    // Same pipeline, same frame: identical above the status line (its frame rate differs).
    EXPECT_EQ(cv::norm(a(cv::Rect(0, 0, 640, 440)), b(cv::Rect(0, 0, 640, 440)), cv::NORM_INF), 0.0);
}

// A live session saves its room memory and the next one starts from it (the format's own tests:
// tests/roommodel/RoomModelFileTest.cpp; replay's: ReplayCommand.SavedRoomModelStartsTheNextReplayWithTheRoomKnown).
TEST(LiveCommand, SavesTheRoomModelAndTheNextSessionStartsWithIt) {
    const fs::path scratch = test::scratchDir("live_room_model");
    const fs::path model = scratch / "recorded" / "room.lsroom"; // in the --record folder, which live makes
    const std::string arguments = "live --device " + (test::sourceDir() / "recordings" / "synth-orbit").string() +
                                  " --scene " + (test::sourceDir() / "recordings" / "scenes" / "orbit.json").string() +
                                  " --pose tracking --headless --fast --max-frames 6";
    ASSERT_EQ(run("",
                  arguments + " --record " + (scratch / "recorded").string() + " --save-room-model " + model.string(),
                  scratch),
              0)
        << stderrOf(scratch);
    std::ifstream file(model, std::ios::binary);
    std::string magic(21, '\0');
    file.read(magic.data(), std::streamsize(magic.size()));
    EXPECT_EQ(magic, "lightskin-room-model\n");
    ASSERT_EQ(run("", arguments + " --room-model " + model.string(), scratch), 0) << stderrOf(scratch);
    EXPECT_NE(stderrOf(scratch).find("room model loaded"), std::string::npos) << stderrOf(scratch);
}
