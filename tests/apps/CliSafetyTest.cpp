// Nothing lost: an output folder is never an input, never holds one and never lies inside one, and
// --overwrite deletes only a folder a lightskin command wrote (it holds .lightskin-output). Each case
// runs the built program and checks that the inputs are byte for byte what they were.
#include "CliRun.h"
#include "TestPaths.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <fstream>
#include <map>

using namespace lightskin;
using namespace lightskin::test::cli;
namespace fs = std::filesystem;

namespace {

/// Every file under `folder` with its size and contents' hash: what "untouched" means here.
std::string snapshot(const fs::path& folder) {
    std::vector<std::string> lines;
    for (const auto& entry : fs::recursive_directory_iterator(folder)) {
        std::string line = fs::relative(entry.path(), folder).string();
        if (entry.path().parent_path() == folder &&
            (entry.path().filename() == "stdout.txt" || entry.path().filename() == "stderr.txt"))
            continue; // runCli's own transcript files
        if (entry.is_regular_file())
            line += " " + std::to_string(std::hash<std::string>{}(test::readText(entry.path())));
        lines.push_back(line);
    }
    std::sort(lines.begin(), lines.end());
    std::string text;
    for (const std::string& line : lines) text += line + "\n";
    return text;
}

/// Expects `r` to be refused before anything was touched: exit 1, one error line naming `contains`.
void expectRefused(const CliRun& r, const std::string& contains) {
    EXPECT_EQ(r.exitCode, 1) << r.err;
    expectOneErrorLine(r, contains);
}

} // namespace

// replay R --out R --overwrite deleted the recording, then failed on its first frame.
TEST(CliSafety, ReplayOutEqualToTheRecordingIsRefused) {
    const Fixture f("cli_safety_out_is_recording");
    const std::string before = snapshot(f.scratch);
    const CliRun r = runCli(f.replay(f.recording, "--overwrite"), f.scratch);
    expectRefused(r, "--out is the input " + f.recording.string());
    EXPECT_EQ(snapshot(f.scratch), before);
    // The same through a symbolic link to the recording, and a folder inside it.
    fs::create_directory_symlink(f.recording, f.scratch / "link");
    const std::string withLink = snapshot(f.scratch);
    expectRefused(runCli(f.replay(f.scratch / "link", "--overwrite"), f.scratch), "--out is the input");
    expectRefused(runCli(f.replay(f.recording / "colour", "--overwrite"), f.scratch), "--out lies inside the input");
    EXPECT_EQ(snapshot(f.scratch), withLink);
}

// --out = a folder that holds the recording and the scene: both were deleted.
TEST(CliSafety, ReplayOutHoldingTheInputsIsRefused) {
    const Fixture f("cli_safety_out_holds_inputs");
    const std::string before = snapshot(f.scratch);
    const fs::path elsewhere = test::scratchDir("cli_safety_out_holds_inputs_cwd");
    const CliRun r = runCli(f.replay(f.scratch, "--overwrite"), f.scratch, elsewhere);
    expectRefused(r, "--out holds the input");
    EXPECT_EQ(snapshot(f.scratch), before);
}

// --out = the scene's folder: the scene and its meshes were deleted and the run exited 0. Here the
// scene is the only input in that folder, and its mesh lies in a third folder that is then --out.
TEST(CliSafety, ReplayOutHoldingTheSceneOrItsMeshesIsRefused) {
    const fs::path scratch = test::scratchDir("cli_safety_scene_folder");
    const fs::path recording = writeRecording(scratch / "recording");
    fs::create_directories(scratch / "scene");
    fs::create_directories(scratch / "meshes");
    fs::copy_file(test::sourceDir() / "recordings" / "scenes" / "meshes" / "cube.obj", scratch / "meshes" / "cube.obj");
    std::string scene = kScene;
    scene.replace(scene.find("\"cube.obj\""), std::string("\"cube.obj\"").size(), "\"../meshes/cube.obj\"");
    std::ofstream(scratch / "scene" / "scene.json") << scene;
    const std::string before = snapshot(scratch);
    const std::string command =
        "replay " + recording.string() + " --scene " + (scratch / "scene" / "scene.json").string();
    expectRefused(runCli(command + " --overwrite --out " + (scratch / "scene").string(), scratch),
                  "--out holds the input " + (scratch / "scene" / "scene.json").string());
    // Without the marker the folder is refused before the scene is read; with one (an earlier run's
    // output that now holds a mesh) once the scene names the mesh.
    expectRefused(runCli(command + " --overwrite --out " + (scratch / "meshes").string(), scratch),
                  ".lightskin-output");
    EXPECT_EQ(snapshot(scratch), before);
    std::ofstream(scratch / "meshes" / ".lightskin-output") << "lightskin replay ...\n";
    const std::string withMarker = snapshot(scratch);
    expectRefused(runCli(command + " --overwrite --out " + (scratch / "meshes").string(), scratch),
                  "--out holds the input " + (scratch / "meshes" / "cube.obj").string());
    EXPECT_EQ(snapshot(scratch), withMarker);
}

// record --source R --out R --overwrite replaced a 40-frame recording by an empty one.
TEST(CliSafety, RecordOutEqualToTheSourceIsRefused) {
    const Fixture f("cli_safety_record_source");
    const std::string before = snapshot(f.scratch);
    const CliRun r = runCli(
        "record --source " + f.recording.string() + " --out " + f.recording.string() + " --overwrite", f.scratch);
    expectRefused(r, "--out is the input " + f.recording.string());
    EXPECT_EQ(snapshot(f.scratch), before);
}

// --overwrite deletes only what a lightskin command wrote: a folder without the marker is the user's.
TEST(CliSafety, OverwriteDeletesOnlyAFolderTheProgramWrote) {
    const Fixture f("cli_safety_marker");
    const fs::path mine = f.scratch / "mine";
    fs::create_directories(mine / "notes");
    std::ofstream(mine / "notes" / "thesis.tex") << "months of work";
    const std::string before = snapshot(mine);
    const CliRun r = runCli(f.replay(mine, "--no-video --overwrite"), f.scratch);
    expectRefused(r, ".lightskin-output");
    EXPECT_EQ(snapshot(mine), before);

    // A folder the program made holds the marker with the command line; --overwrite may clear it.
    const fs::path out = f.scratch / "out";
    ASSERT_EQ(runCli(f.replay(out, "--no-video"), f.scratch).exitCode, 0);
    const std::string marker = test::readText(out / ".lightskin-output");
    EXPECT_NE(marker.find(" replay " + f.recording.string()), std::string::npos) << marker;
    std::ofstream(out / "stale.txt") << "an earlier run's file";
    const CliRun again = runCli(f.replay(out, "--no-video --overwrite"), f.scratch);
    EXPECT_EQ(again.exitCode, 0) << again.err;
    EXPECT_FALSE(fs::exists(out / "stale.txt"));
    EXPECT_TRUE(fs::exists(out / ".lightskin-output"));
}

// The fakenect size is in the source's header: a 320x240 recording is refused before anything is written.
TEST(CliSafety, RecordToFakenectChecksTheSizeFirst) {
    const fs::path scratch = test::scratchDir("cli_safety_fakenect");
    const fs::path orbit = test::sourceDir() / "recordings" / "synth-orbit";
    const CliRun r =
        runCli("record --to-fakenect --source " + orbit.string() + " --out " + (scratch / "dump").string(), scratch);
    expectRefused(r, "--to-fakenect needs 640x480 frames (fakenect's only resolution); the colour images are 320x240");
    EXPECT_FALSE(fs::exists(scratch / "dump"));
}

// File outputs: never an input, and a name OpenCV cannot write is refused before any work, naming the option.
TEST(CliSafety, ImageOutputsAreCheckedFirst) {
    const Fixture f("cli_safety_file_outputs");
    const CliRun doctor = runCli("doctor --out self.test", f.scratch);
    EXPECT_EQ(doctor.exitCode, 1);
    expectOneErrorLine(doctor, "--out needs an image file name ending in .png");
    EXPECT_EQ(doctor.out, "") << "the checks ran before --out was refused";

    const fs::path actual = f.scratch / "a.actual.png";
    cv::imwrite(actual.string(), cv::Mat(4, 4, CV_16UC3, cv::Scalar(1000, 2000, 3000)));
    const CliRun diff = runCli("golden-diff " + actual.string() + " " + actual.string() + " --diff d.xyz", f.scratch);
    EXPECT_EQ(diff.exitCode, 1);
    expectOneErrorLine(diff, "--diff needs an image file name ending in .png");
    const std::string before = test::readText(actual);
    const CliRun self = runCli("golden-diff " + actual.string() + " g.png --diff " + actual.string(), f.scratch);
    EXPECT_EQ(self.exitCode, 1);
    expectOneErrorLine(self, "--diff is the input");
    EXPECT_EQ(test::readText(actual), before);
}

// docs/CLI.md's rules on options, run: contradictions and no-ops are refused with the reason, deprecated
// spellings never silently lose to the new ones, -q silences progress, report.json's command is the argv.
TEST(CliRules, OptionsThatWouldDoNothingAreRefused) {
    const Fixture f("cli_rules_no_ops");
    const fs::path out = f.scratch / "out";
    for (const auto& [options, says] : std::vector<std::pair<std::string, std::string>>{
             {"--no-video --video-format avi", "--no-video excludes --video-format"},
             {"--no-video --side-by-side-video", "--no-video excludes --side-by-side-video"},
             {"--no-compare --side-by-side-video", "--side-by-side-video excludes --no-compare"},
             {"--frames 0 --write-frames 1",
              "--frames: is the deprecated spelling of --write-frames; give only --write-frames"},
             {"--write-frames ''", "got an empty value"},
             {"--write-frames 5-2", "runs backwards"},
             {"--budget-ms nan", "--budget-ms"},
         }) {
        SCOPED_TRACE(options);
        const CliRun r = runCli(f.replay(out, options), f.scratch);
        EXPECT_EQ(r.exitCode, 64) << r.err;
        expectOneErrorLine(r, says);
        EXPECT_FALSE(fs::exists(out));
    }
    const CliRun record = runCli(
        "record --source " + f.recording.string() + " --out " + out.string() + " --frames 1 --max-frames 2", f.scratch);
    EXPECT_EQ(record.exitCode, 64) << record.err;
    expectOneErrorLine(record, "--frames: is the deprecated spelling of --max-frames");
    // A fakenect dump has its own format: the recording's storage options would do nothing there.
    const CliRun fakenectJpeg =
        runCli("record --to-fakenect --jpeg --source " + f.recording.string() + " --out " + out.string(), f.scratch);
    EXPECT_EQ(fakenectJpeg.exitCode, 64) << fakenectJpeg.err;
    EXPECT_NE(fakenectJpeg.err.find("excludes"), std::string::npos) << fakenectJpeg.err;
    EXPECT_NE(fakenectJpeg.err.find("--jpeg"), std::string::npos) << fakenectJpeg.err;
    EXPECT_NE(fakenectJpeg.err.find("--to-fakenect"), std::string::npos) << fakenectJpeg.err;
    EXPECT_FALSE(fs::exists(out));
    // Only the input shows these: exit 1, before anything is written.
    const CliRun raw = runCli(f.replay(out, "--raw-depth"), f.scratch);
    EXPECT_EQ(raw.exitCode, 1) << raw.err;
    expectOneErrorLine(raw, "--raw-depth: would do nothing: the depth of " + f.recording.string() +
                                " is registered to colour already");
    EXPECT_FALSE(fs::exists(out));
    // Outputs are checked before any work: a file where a folder is needed fails at once.
    std::ofstream(f.scratch / "afile") << "x";
    const CliRun snapshot = runCli("live --headless --device " + f.recording.string() + " --scene " + f.scene.string() +
                                       " --snapshot-after 1 --snapshot-dir " + (f.scratch / "afile").string(),
                                   f.scratch);
    EXPECT_EQ(snapshot.exitCode, 1) << snapshot.err;
    expectOneErrorLine(snapshot, "afile");
    EXPECT_EQ(snapshot.out, "") << "GL was set up before the check";
}

TEST(CliRules, QuietSilencesProgressAndTheReportHoldsTheExactCommand) {
    const Fixture f("cli_rules_quiet");
    const fs::path out = f.scratch / "out";
    const std::string arguments = f.replay(out, "--no-video --write-frames '0,2-3' -q");
    const CliRun r = runCli(arguments, f.scratch);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(r.err.find("replay: frame"), std::string::npos) << r.err;
    const nlohmann::json report = nlohmann::json::parse(test::readText(out / "report.json"));
    std::string expected = program() + " " + arguments;
    expected.replace(expected.find("'0,2-3'"), 7, "0,2-3"); // needs no quotes: written without
    EXPECT_EQ(report["command"], expected);
}

// A scene without virtual objects is valid for every technique: the camera image comes out as it went
// in (the wall is one flat colour), GI idles, and the report says why.
TEST(CliRules, ASceneWithoutObjectsShowsTheRoomAlone) {
    const Fixture f("cli_rules_empty_scene");
    for (const std::string technique : {"lightskin", "brute-force", "imperfect-volumes", "multiscale-prt", "none"}) {
        for (const std::string objects : {"\"objects\": [], ", ""}) {
            const std::string name = technique + (objects.empty() ? "-absent" : "-empty");
            SCOPED_TRACE(name);
            const fs::path scene = f.scratch / (name + ".json");
            std::ofstream(scene)
                << "{\"version\": 1, " << objects
                << "\"lights\": [{\"type\": \"point\", \"position\": [0.3, 0.2, 1.0], \"power\": 30}], "
                   "\"gi\": {\"technique\": \""
                << technique << "\"}}";
            const fs::path out = f.scratch / name;
            const CliRun r = runCli("replay " + f.recording.string() + " --scene " + scene.string() + " --out " +
                                        out.string() + " --no-video",
                                    f.scratch);
            ASSERT_EQ(r.exitCode, 0) << r.err;
            const nlohmann::json report = nlohmann::json::parse(test::readText(out / "report.json"));
            EXPECT_EQ(report["status"], "complete");
            EXPECT_EQ(report["giActiveFrames"], 0);
            if (technique != "none") {
                EXPECT_EQ(report["giInactiveCauses"]["the scene has no virtual objects: the real room is shown alone"],
                          test::kWallFrames)
                    << report["giInactiveCauses"].dump();
            }
            const cv::Mat frame = cv::imread((out / "frames" / "000003.png").string(), cv::IMREAD_COLOR);
            ASSERT_FALSE(frame.empty());
            EXPECT_EQ(cv::countNonZero(frame.reshape(1) !=
                                       cv::Mat(frame.size(), CV_8UC3, cv::Scalar(40, 90, 160)).reshape(1)),
                      0);
        }
    }
}
