#pragma once
// Running the built `lightskin` program in tests: its exit code, stdout and stderr, the files it left,
// and the one-error-line rule (docs/CLI.md). Set LIGHTSKIN_TEST_PROGRAM to run the tests against
// another build.
#include "TestPaths.h"
#include "WallRecording.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace lightskin::test::cli {

namespace fs = std::filesystem;

inline std::string program() {
    const char* other = std::getenv("LIGHTSKIN_TEST_PROGRAM");
    return other != nullptr ? other : LIGHTSKIN_PROGRAM;
}

/// The shared 6-frame 64x48 wall recording (tests/support/WallRecording.h), one flat colour.
inline fs::path writeRecording(const fs::path& folder) {
    return lightskin::test::writeWallRecording(
        folder, [](int, int) { return cv::Vec3b(40, 90, 160); }, "cli test");
}

// A cube lit by a point light, no GI technique: the fastest scene that renders virtual content.
inline const std::string kScene = R"({"version": 1,
  "objects": [{"name": "cube", "mesh": "cube.obj", "transform": {"translation": [0, 0, 0.1], "scale": 0.2}}],
  "lights": [{"type": "point", "position": [0.3, 0.2, 1.0], "power": 30}],
  "gi": {"technique": "none"}})";

struct CliRun {
    int exitCode = -1;
    std::string out, err;
    /// stderr's lines (what a user reads).
    std::vector<std::string> errLines() const {
        std::vector<std::string> lines;
        std::istringstream stream(err);
        for (std::string line; std::getline(stream, line);)
            if (!line.empty()) lines.push_back(line);
        return lines;
    }
};

/// Runs `lightskin <arguments>` in `cwd` (default: the scratch folder), through `wrapper` (e.g. setpriv).
inline CliRun runCli(const std::string& arguments, const fs::path& scratch, const fs::path& cwd = {},
                     const std::string& wrapper = {}) {
    const fs::path out = scratch / "stdout.txt", err = scratch / "stderr.txt";
    CliRun r;
    r.exitCode =
        lightskin::test::runShell("cd " + (cwd.empty() ? scratch : cwd).string() + " && " + wrapper + program() + " " +
                                  arguments + " > " + out.string() + " 2> " + err.string() + " < /dev/null");
    r.out = lightskin::test::readText(out);
    r.err = lightskin::test::readText(err);
    return r;
}

/// The files under `folder`, relative, sorted ("" when it does not exist).
inline std::string listing(const fs::path& folder) {
    if (!fs::exists(folder)) return "<missing>";
    std::vector<std::string> names;
    for (const auto& entry : fs::recursive_directory_iterator(folder))
        names.push_back(fs::relative(entry.path(), folder).string());
    std::sort(names.begin(), names.end());
    std::string text;
    for (const auto& name : names) text += name + "\n";
    return text;
}

struct Fixture {
    fs::path scratch, recording, scene;
    explicit Fixture(const std::string& name)
        : scratch(lightskin::test::scratchDir(name)) {
        recording = writeRecording(scratch / "recording");
        fs::copy_file(lightskin::test::sourceDir() / "recordings" / "scenes" / "meshes" / "cube.obj",
                      scratch / "cube.obj");
        scene = scratch / "scene.json";
        std::ofstream(scene) << kScene;
    }
    std::string replay(const fs::path& out, const std::string& options = "") const {
        return "replay " + recording.string() + " --scene " + scene.string() + " --out " + out.string() +
               (options.empty() ? "" : " " + options);
    }
};

/// The error line every failure ends with: exactly one stderr line starts with "lightskin", it is the
/// last, and no raw third-party line (libpng, OpenCV's "[ WARN") was printed.
inline void expectOneErrorLine(const CliRun& r, const std::string& contains) {
    const auto lines = r.errLines();
    ASSERT_FALSE(lines.empty());
    EXPECT_NE(lines.back().find(contains), std::string::npos) << r.err;
    EXPECT_EQ(lines.back().rfind("lightskin", 0), 0u) << r.err;
    EXPECT_EQ(r.err.find("libpng"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("[ WARN"), std::string::npos) << r.err;
}

} // namespace lightskin::test::cli
