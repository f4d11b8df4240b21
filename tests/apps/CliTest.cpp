// The command line a user can trust. Golden CLI transcripts of the built program: the exit
// code, the one error line, and the files left behind, for each point of the issue and for the
// general rules on every subcommand (docs/CLI.md). Set LIGHTSKIN_TEST_PROGRAM to run them against
// another build (e.g. main's, to see them fail there).
#include "CliRun.h"
#include "TestPaths.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <unistd.h>

using namespace lightskin;
using namespace lightskin::test::cli;
namespace fs = std::filesystem;

// Point 1 and the output-folder rule: replay into a used folder is refused; --overwrite clears it.
TEST(Cli, ReplayRefusesAUsedOutputFolderAndOverwriteClearsIt) {
    const Fixture f("cli_replay_overwrite");
    const fs::path out = f.scratch / "out";
    ASSERT_EQ(runCli(f.replay(out, "--no-video"), f.scratch).exitCode, 0);
    std::ofstream(out / "frames" / "999999.png") << "an earlier run's frame";
    const std::string before = listing(out);

    const CliRun again = runCli(f.replay(out, "--no-video"), f.scratch);
    EXPECT_EQ(again.exitCode, 1);
    expectOneErrorLine(again, "--overwrite");
    EXPECT_NE(again.err.find(out.string()), std::string::npos) << again.err;
    EXPECT_EQ(listing(out), before); // untouched

    const CliRun overwrite = runCli(f.replay(out, "--no-video --overwrite"), f.scratch);
    ASSERT_EQ(overwrite.exitCode, 0) << overwrite.err;
    EXPECT_FALSE(fs::exists(out / "frames" / "999999.png"));
    EXPECT_TRUE(fs::exists(out / "frames" / "000005.png"));
}

// Point 2: a truncated PNG at frame 3 keeps frames 0-2, the video and a report marked failed; one
// clear error line that says what was kept; libpng's own line only in the log (-v).
TEST(Cli, AFailureMidReplayKeepsAReportMarkedFailed) {
    const Fixture f("cli_replay_failure");
    const fs::path png = f.recording / "colour" / "000003.png";
    ASSERT_TRUE(fs::exists(png));
    fs::resize_file(png, 60); // the signature and part of IHDR: libpng fails while decoding
    const fs::path out = f.scratch / "out";
    const CliRun r = runCli(f.replay(out), f.scratch);
    EXPECT_EQ(r.exitCode, 1);
    expectOneErrorLine(r, "kept in " + out.string() + ": 3 frames");
    EXPECT_NE(r.errLines().back().find("000003.png"), std::string::npos) << r.err;
    EXPECT_EQ(listing(out / "frames"), "000000.png\n000001.png\n000002.png\n");
    const nlohmann::json report = nlohmann::json::parse(test::readText(out / "report.json"));
    EXPECT_EQ(report["status"], "failed");
    EXPECT_NE(report["failure"].get<std::string>().find("000003.png"), std::string::npos);
    EXPECT_EQ(report["framesRead"], 3);
    EXPECT_EQ(report["frames"].size(), 3u);
    ASSERT_FALSE(report["video"].get<std::string>().empty());
    EXPECT_GT(fs::file_size(out / report["video"].get<std::string>()), 0u);
    EXPECT_NE(test::readText(out / "report.md").find("FAILED"), std::string::npos);

    // The library's own words are kept, in the log with their source, for -v.
    const CliRun verbose = runCli(f.replay(f.scratch / "out-verbose", "-v --no-video"), f.scratch);
    EXPECT_EQ(verbose.exitCode, 1);
    EXPECT_NE(verbose.err.find("[debug] libpng: libpng error"), std::string::npos) << verbose.err;
}

// Point 3: settings that would do nothing are refused before anything is written.
TEST(Cli, SettingsThatWouldDoNothingAreRefused) {
    const Fixture f("cli_do_nothing");
    const fs::path out = f.scratch / "out";
    const auto refused = [&](const std::string& arguments, int code, const std::string& says) {
        SCOPED_TRACE(arguments);
        const CliRun r = runCli(arguments, f.scratch);
        EXPECT_EQ(r.exitCode, code);
        expectOneErrorLine(r, says);
        EXPECT_FALSE(fs::exists(out)) << listing(out);
    };
    refused(f.replay(out, "--write-frames 999"), 1, "--write-frames");
    refused(f.replay(out, "--write-frames 4 --max-frames 3"), 1, "--max-frames 3 stops before it");
    refused(f.replay(out, "--max-frames -1"), 64, "--max-frames");
    refused(f.replay(out, "--max-frames 0"), 64, "--max-frames");
    refused(f.replay(out, "--static-tolerance 0.1"), 64, "--static-tolerance requires --adaptive");
    refused("record --source " + f.recording.string() + " --out " + out.string() + " --max-frames 0", 64,
            "--max-frames");
    refused("synth " + f.scene.string() + " --out " + out.string() + " --max-frames 0", 64, "--max-frames");
    refused("live --headless --fast --device " + f.recording.string() + " --scene " + f.scene.string() +
                " --snapshot-after 100 --snapshot " + (out / "s.png").string(),
            1, "--snapshot-after");
}

// Point 4: --out that is a file, or inside a file, reads like record's message, exit 1, on every
// command with an output folder.
TEST(Cli, OutputFolderThatIsAFileIsAClearError) {
    const Fixture f("cli_out_file");
    const fs::path file = f.scratch / "a-file";
    std::ofstream(file) << "x";
    const std::vector<std::string> commands = {f.replay(file),
                                               "record --source " + f.recording.string() + " --out " + file.string(),
                                               "synth " + f.scene.string() + " --out " + file.string(),
                                               "live --headless --fast --device " + f.recording.string() + " --scene " +
                                                   f.scene.string() + " --record " + file.string()};
    for (const std::string& command : commands) {
        SCOPED_TRACE(command);
        const CliRun r = runCli(command, f.scratch);
        EXPECT_EQ(r.exitCode, 1);
        expectOneErrorLine(r, file.string() + ": exists and is not a folder");
        const CliRun inside = runCli(command + "/sub", f.scratch);
        EXPECT_EQ(inside.exitCode, 1);
        expectOneErrorLine(inside, file.string() + " is not a folder");
        EXPECT_EQ(test::readText(file), "x");
    }
    // A folder without write permission. Root writes into any folder, and CI runs as root: there the
    // program runs as the unprivileged user nobody (setpriv), for whom the folder is read-only.
    const fs::path locked = f.scratch / "locked";
    fs::create_directories(locked);
    fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec | fs::perms::group_read |
                                fs::perms::group_exec | fs::perms::others_read | fs::perms::others_exec);
    const bool root = ::geteuid() == 0;
    if (root) {
        ASSERT_EQ(test::runShell("command -v setpriv > /dev/null"), 0) << "setpriv (util-linux) is needed as root";
    }
    const CliRun r = runCli(f.replay(locked / "out"), f.scratch, {},
                            root ? "setpriv --reuid=nobody --regid=nogroup --clear-groups " : "");
    fs::permissions(locked, fs::perms::owner_all);
    EXPECT_EQ(r.exitCode, 1);
    expectOneErrorLine(r, locked.string() + " is not writable");
    EXPECT_EQ(listing(locked), "");
    // A name longer than the file system's limit (255 bytes on ext4, tmpfs, overlayfs) fails for root
    // too; it is refused before anything is written, not at mkdir.
    const fs::path tooLong = f.scratch / "fresh" / std::string(300, 'n');
    const CliRun longName = runCli(f.replay(tooLong), f.scratch);
    EXPECT_EQ(longName.exitCode, 1);
    expectOneErrorLine(longName, "has 300 characters, more than the 255 the file system allows");
    EXPECT_FALSE(fs::exists(f.scratch / "fresh"));
}

// The output-folder rule on every command that writes a folder: a used one is refused (naming
// --overwrite) and left as it was; --overwrite clears it first.
TEST(Cli, EveryOutputFolderIsNewOrEmptyOrOverwritten) {
    const Fixture f("cli_every_out");
    const fs::path used = f.scratch / "used";
    const std::vector<std::string> commands = {
        f.replay(used, "--no-video"),
        "record --source " + f.recording.string() + " --max-frames 2 --out " + used.string(),
        "live --headless --fast --max-frames 2 --device " + f.recording.string() + " --scene " + f.scene.string() +
            " --record " + used.string()};
    for (const std::string& command : commands) {
        SCOPED_TRACE(command);
        fs::remove_all(used);
        fs::create_directories(used);
        std::ofstream(used / "earlier.txt") << "keep me unless --overwrite";
        const CliRun r = runCli(command, f.scratch);
        EXPECT_EQ(r.exitCode, 1);
        expectOneErrorLine(r, "add --overwrite");
        EXPECT_EQ(listing(used), "earlier.txt\n");
        // --overwrite deletes only a folder a lightskin command wrote: here an earlier run's.
        std::ofstream(used / ".lightskin-output") << "lightskin ...\n";
        const CliRun overwrite = runCli(command + " --overwrite", f.scratch);
        EXPECT_EQ(overwrite.exitCode, 0) << overwrite.err;
        EXPECT_FALSE(fs::exists(used / "earlier.txt"));
        EXPECT_NE(listing(used), "") << "nothing written";
    }
    // synth checks its folder before reading the scene description.
    const CliRun synth = runCli("synth " + f.scene.string() + " --out " + used.string(), f.scratch);
    EXPECT_EQ(synth.exitCode, 1);
    expectOneErrorLine(synth, "add --overwrite");
}

// Point 6: one vocabulary, global options anywhere, unknown commands named, defaults shown one way,
// shipped data found from any folder.
TEST(Cli, OptionsMeanOneThingEverywhere) {
    const Fixture f("cli_vocabulary");
    const CliRun bogus = runCli("bogus", f.scratch);
    EXPECT_EQ(bogus.exitCode, 64);
    expectOneErrorLine(bogus, "unknown command 'bogus'");
    EXPECT_NE(bogus.err.find("replay"), std::string::npos);

    // Counts are --max-frames everywhere; replay's PNG list is --write-frames.
    for (const std::string command : {"record", "synth", "replay", "live"}) {
        const CliRun help = runCli(command + " --help", f.scratch);
        EXPECT_EQ(help.exitCode, 0);
        EXPECT_NE(help.out.find("--max-frames"), std::string::npos) << command;
        EXPECT_EQ(help.out.find("--frames"), std::string::npos) << command << ": deprecated spellings are hidden";
    }
    EXPECT_NE(runCli("replay --help", f.scratch).out.find("--write-frames TEXT=all"), std::string::npos);
    // Defaults shown as OPTION TYPE=value, also for live --device and the bench commands.
    EXPECT_NE(runCli("live --help", f.scratch).out.find("--device TEXT=freenect://0"), std::string::npos);
    EXPECT_NE(runCli("bench-embed --help", f.scratch).out.find("--frames INT:INT in [1 - 100000]=10"),
              std::string::npos);

    // The old spelling still works, with a warning.
    const CliRun old =
        runCli("record --source " + f.recording.string() + " --out " + (f.scratch / "rec").string() + " --frames 2",
               f.scratch);
    EXPECT_EQ(old.exitCode, 0) << old.err;
    EXPECT_NE(old.err.find("--frames is deprecated, use --max-frames"), std::string::npos) << old.err;
    EXPECT_NE(old.out.find("recorded 2 frames"), std::string::npos) << old.out;

    // -q after the subcommand: no info lines.
    const CliRun quiet = runCli(f.replay(f.scratch / "quiet", "--no-video -q"), f.scratch);
    EXPECT_EQ(quiet.exitCode, 0) << quiet.err;
    EXPECT_EQ(quiet.err.find("[info]"), std::string::npos) << quiet.err;
    const CliRun loud = runCli(f.replay(f.scratch / "loud", "--no-video"), f.scratch);
    EXPECT_NE(loud.err.find("[info]"), std::string::npos) << "-q above proves nothing without info lines here";

    // The bunny is found from a folder that has no tests/data (here: the scratch folder).
    const CliRun bench =
        runCli("bench-static --frames 1 --width 32 --height 24 --sparse 32 --tolerances 0.1", f.scratch);
    EXPECT_EQ(bench.exitCode, 0) << bench.err;
    EXPECT_EQ(bench.err.find("bunny"), std::string::npos) << bench.err;
}

/// The "  name   description" lines of a --help's subcommand list, by name.
std::map<std::string, std::string> commandDescriptions(const std::string& help) {
    std::map<std::string, std::string> descriptions;
    std::istringstream lines(help);
    bool inList = false;
    for (std::string line; std::getline(lines, line);) {
        if (line.rfind("Subcommands:", 0) == 0) inList = true;
        if (!inList || line.rfind("  ", 0) != 0) continue;
        const std::size_t nameEnd = line.find(' ', 2), text = line.find_first_not_of(' ', nameEnd);
        if (nameEnd != std::string::npos && text != std::string::npos)
            descriptions[line.substr(2, nameEnd - 2)] = line.substr(text);
    }
    return descriptions;
}

// Point 7 (top-level help): every tool command forwarded to lightskin-tools is described by the words its
// own program uses (one table, ToolCommands.h), not by a generic "Developer tool" line.
TEST(Cli, TopLevelHelpDescribesEachToolCommandAsTheToolDoes) {
    const fs::path scratch = test::scratchDir("cli_tool_help");
    const CliRun top = runCli("--help", scratch);
    ASSERT_EQ(top.exitCode, 0);
    const fs::path tools = fs::path(program()).parent_path() / "lightskin-tools";
    ASSERT_EQ(test::runShell(tools.string() + " --help > " + (scratch / "tools.txt").string()), 0);
    const auto ours = commandDescriptions(top.out), theirs = commandDescriptions(test::readText(scratch / "tools.txt"));
    ASSERT_GE(theirs.size(), 9u) << test::readText(scratch / "tools.txt"); // synth and the 8 bench commands
    for (const auto& [name, description] : theirs) {
        SCOPED_TRACE(name);
        ASSERT_TRUE(ours.contains(name)) << "lightskin does not forward it:\n" << top.out;
        EXPECT_EQ(ours.at(name), description);
        EXPECT_EQ(description.find("Developer tool in"), std::string::npos);
    }
    // The forwarded ones are marked as a group of their own, and only they.
    EXPECT_NE(top.out.find("Developer tools (the program lightskin-tools"), std::string::npos) << top.out;
    for (const auto& [name, description] : ours) {
        if (!theirs.contains(name)) {
            EXPECT_EQ(name.rfind("bench", 0), std::string::npos) << name;
        }
    }
}

// Point 7: labels say what happened.
TEST(Cli, LabelsSayWhatHappened) {
    const Fixture f("cli_labels");
    for (const std::string pose : {"fixed", "ground-truth"}) {
        const fs::path out = f.scratch / ("out-" + pose);
        const CliRun r = runCli(f.replay(out, "--no-video --pose " + pose), f.scratch);
        ASSERT_EQ(r.exitCode, 0) << r.err;
        const nlohmann::json report = nlohmann::json::parse(test::readText(out / "report.json"));
        for (const auto& frame : report["frames"]) EXPECT_EQ(frame["tracking"], pose);
    }
    // Without a GI technique the status line names no GI channels; the pose says where it came from.
    const CliRun live = runCli("live --headless --fast --max-frames 1 --device " + f.recording.string() + " --scene " +
                                   f.scene.string(),
                               f.scratch);
    ASSERT_EQ(live.exitCode, 0) << live.err;
    EXPECT_NE(live.err.find("GI none |"), std::string::npos) << live.err;
    EXPECT_EQ(live.err.find("+glossy"), std::string::npos) << live.err;
    EXPECT_NE(live.err.find("| ground-truth"), std::string::npos) << live.err;

    // synth's progress says how long is left.
    const CliRun synth = runCli("synth " + (test::sourceDir() / "recordings" / "scenes-synth" / "orbit.json").string() +
                                    " --max-frames 2 --out " + (f.scratch / "synth").string(),
                                f.scratch);
    ASSERT_EQ(synth.exitCode, 0) << synth.err;
    EXPECT_NE(synth.err.find("synth: frame 2 of 2"), std::string::npos) << synth.err;
    EXPECT_NE(synth.err.find("ETA"), std::string::npos) << synth.err;

    // A hold reason names the option a user sets (an impossible 0.001 px refuses every measurement).
    const fs::path pan = test::sourceDir() / "recordings" / "synth-pan";
    const CliRun held = runCli("track --world " + (pan / "synth" / "tag-world.json").string() +
                                   " --decimate 1 --max-corner-std 0.001 " + pan.string(),
                               f.scratch);
    EXPECT_NE(held.out.find("--max-corner-std"), std::string::npos) << held.out;
    EXPECT_EQ(held.out.find("maxWorldCornerStdPx"), std::string::npos) << held.out;

    // track: a missing image fails before the first line, without OpenCV's warning.
    const CliRun track = runCli("track --tag-id 0 --tag-size 0.1 missing.png", f.scratch);
    EXPECT_EQ(track.exitCode, 1);
    expectOneErrorLine(track, "missing.png: frame 0: no such image file");
    EXPECT_EQ(track.out, "");
}

// Point 5: scene errors are found before anything is written and name the key and the way out.
TEST(Cli, SceneErrorsComeFirstAndNameTheKey) {
    const Fixture f("cli_scene_errors");
    const fs::path out = f.scratch / "out";
    const auto refused = [&](const std::string& scene, const std::string& options, const std::string& says) {
        SCOPED_TRACE(scene);
        const fs::path path = f.scratch / "bad-scene.json";
        std::ofstream(path) << scene;
        const CliRun r = runCli("replay " + f.recording.string() + " --scene " + path.string() + " --out " +
                                    out.string() + " " + options,
                                f.scratch);
        EXPECT_EQ(r.exitCode, 1);
        expectOneErrorLine(r, says);
        EXPECT_FALSE(fs::exists(out)) << listing(out);
    };
    std::ofstream(f.scratch / "garbage.obj") << "this is not a mesh\n\x01\x02\n";
    refused(R"({"version": 1, "objects": [{"mesh": "garbage.obj"}], "gi": {"technique": "none"}})", "",
            "garbage.obj: not a readable .obj mesh");
    refused(R"({"version": 1, "objects": [{"mesh": "cube.obj"}], "gi": {"technique": "none"}})", "--pose tracking",
            "--pose fixed");
    refused(R"({"version": 1, "objects": [{"mesh": "cube.obj"}], "gi": {"technique": "none"},
                "tracking": {"file": "no-such-world.json"}})",
            "--pose tracking", "/tracking/file: tag world");
}

// Point 5: detector settings and an inline tag world read like every other scene error: "<scene file>:
// <JSON pointer>: <cause>" (before: "<file> /tracking/detector: /quadDecimat: ..." and the library's
// "quad_decimate: must be in [1, 16]" with no file at all), found before anything is written.
TEST(Cli, DetectorAndTagWorldErrorsReadLikeSceneErrors) {
    const Fixture f("cli_detector_errors");
    const fs::path out = f.scratch / "out", path = f.scratch / "bad-scene.json";
    const auto errorLine = [&](const std::string& tracking) {
        std::ofstream(path) << R"({"version": 1, "objects": [{"mesh": "cube.obj"}], "gi": {"technique": "none"},
                                    "tracking": )" +
                                   tracking + "}";
        const CliRun r = runCli("replay " + f.recording.string() + " --scene " + path.string() + " --out " +
                                    out.string() + " --pose tracking",
                                f.scratch);
        EXPECT_EQ(r.exitCode, 1) << tracking;
        EXPECT_FALSE(fs::exists(out)) << listing(out);
        return r.errLines().empty() ? std::string() : r.errLines().back();
    };
    const std::string file = "lightskin: error: " + path.string() + ": ";
    const std::string tag = R"("tag": {"id": 0, "size": 0.1})";
    // The scene's own format, for comparison: the same file, then the JSON pointer, then the cause.
    EXPECT_EQ(errorLine("{" + tag + R"(, "useDepth": 3})"), file + "/tracking/useDepth: expected true or false, got 3");
    EXPECT_EQ(errorLine("{" + tag + R"(, "detector": {"quadDecimate": -2}})"),
              file + "/tracking/detector/quadDecimate: expected a number in [1, 16], got -2");
    EXPECT_EQ(
        errorLine("{" + tag + R"(, "detector": {"quadDecimat": 1}})")
            .rfind(file + "/tracking/detector/quadDecimat: unknown key; expected one of: family, quadDecimate", 0),
        0u);
    EXPECT_EQ(errorLine("{" + tag + R"(, "detector": {"refineEdges": "yes"}})"),
              file + "/tracking/detector/refineEdges: expected true or false, got \"yes\"");
    EXPECT_EQ(errorLine(R"({"tag": {"id": 0, "size": -0.1}})"),
              file + "/tracking/tag/size: expected the black-border edge length in metres, between 0.001 and 100, "
                     "got -0.1");
    EXPECT_EQ(errorLine(R"({"tags": [{"id": 0, "size": 0.1, "positon": [0, 0, 0]}]})"),
              file + "/tracking/tags/0/positon: unknown key; expected one of: id, size, position, orientation");
    // A tag world in a file of its own: that file, and the pointer within it.
    const fs::path world = f.scratch / "world.json";
    std::ofstream(world) << R"({"tags": [{"id": "zero", "size": 0.1}]})";
    EXPECT_EQ(errorLine(R"({"file": "world.json"})"),
              "lightskin: error: " + world.string() + ": /tags/0/id: expected an integer tag id, got \"zero\"");
    // track's own options name the option.
    const CliRun track = runCli("track --tag-id 0 --tag-size 0.1 --decimate -1 missing.png", f.scratch);
    EXPECT_EQ(track.exitCode, 64);
    expectOneErrorLine(track, "--decimate: expected a number in [1, 16], got '-1'");
}

// The validate-before-write rule for synth's --objects-present (a lightskin scene read only after the
// recording had been started before: a missing or broken one left a half-written folder behind).
TEST(Cli, SynthReadsObjectsPresentBeforeWritingAnything) {
    const Fixture f("cli_synth_objects_present");
    const fs::path out = f.scratch / "out";
    const std::string synth = "synth " + (test::sourceDir() / "recordings" / "scenes-synth" / "orbit.json").string() +
                              " --max-frames 1 --out " + out.string() + " --objects-present ";
    const CliRun missing = runCli(synth + (f.scratch / "no-such-scene.json").string(), f.scratch);
    EXPECT_EQ(missing.exitCode, 1);
    expectOneErrorLine(missing, "no-such-scene.json");
    EXPECT_FALSE(fs::exists(out)) << listing(out);

    std::ofstream(f.scratch / "garbage.obj") << "this is not a mesh\n\x01\x02\n";
    std::ofstream(f.scratch / "garbage-scene.json")
        << R"({"version": 1, "objects": [{"mesh": "garbage.obj"}], "gi": {"technique": "none"}})";
    const CliRun garbage = runCli(synth + (f.scratch / "garbage-scene.json").string(), f.scratch);
    EXPECT_EQ(garbage.exitCode, 1);
    expectOneErrorLine(garbage, "garbage.obj");
    EXPECT_FALSE(fs::exists(out)) << listing(out);

    // The valid scene beside it is accepted (the refusals above are about the file, not the option).
    const CliRun good = runCli(synth + f.scene.string(), f.scratch);
    EXPECT_EQ(good.exitCode, 0) << good.err;
    EXPECT_TRUE(fs::exists(out / "synth" / "present" / "000000.png")) << listing(out);
}

// Third-party logs: OpenNI2's (a corrupt .oni) and assimp's (a garbage mesh) reach our log
// with their source, shown with -v, and never the terminal raw: stdout is clean, every stderr line is
// ours (the log's "[level]" lines or the one error line).
TEST(Cli, OpenNi2AndAssimpLogsGoIntoOurLogWithTheirSource) {
    const Fixture f("cli_third_party_logs");
    const auto expectOnlyOurLines = [](const CliRun& r) {
        EXPECT_EQ(r.out, "");
        for (const std::string& line : r.errLines())
            EXPECT_TRUE(line.rfind("[", 0) == 0 || line.rfind("lightskin", 0) == 0) << "raw line: " << line;
    };
    // Not an .oni at all: OpenNI2 logs "Couldn't open device" at ERROR severity.
    std::ofstream(f.scratch / "corrupt.oni") << std::string(4096, 'x');
    const CliRun oni = runCli("info -v " + (f.scratch / "corrupt.oni").string(), f.scratch);
    EXPECT_EQ(oni.exitCode, 1);
    expectOneErrorLine(oni, "corrupt.oni: OpenNI2 cannot open the file");
    expectOnlyOurLines(oni);
    EXPECT_NE(oni.err.find("[debug] OpenNI2: ERROR OniContext: Couldn't open device"), std::string::npos) << oni.err;
    const CliRun quiet = runCli("info " + (f.scratch / "corrupt.oni").string(), f.scratch);
    EXPECT_EQ(quiet.errLines().size(), 1u) << quiet.err; // without -v: the error line only

    // A garbage mesh: assimp's validation error, with its source.
    std::ofstream(f.scratch / "garbage.obj") << "this is not a mesh\n\x01\x02\n";
    std::ofstream(f.scratch / "garbage-scene.json")
        << R"({"version": 1, "objects": [{"mesh": "garbage.obj"}], "gi": {"technique": "none"}})";
    const CliRun mesh =
        runCli("replay -v " + f.recording.string() + " --scene " + (f.scratch / "garbage-scene.json").string() +
                   " --out " + (f.scratch / "out").string(),
               f.scratch);
    EXPECT_EQ(mesh.exitCode, 1);
    expectOneErrorLine(mesh, "garbage.obj: not a readable .obj mesh");
    expectOnlyOurLines(mesh);
    EXPECT_NE(mesh.err.find("[debug] assimp: Error, "), std::string::npos) << mesh.err;
}

// Point 7: with --view vals the comparison shows the VALs over the composite beside the composite
// without GI: neither its labels, nor the report's heading, nor its folder call it "with GI".
TEST(Cli, ValsViewComparisonSaysWhatItShows) {
    const Fixture f("cli_vals_view");
    const fs::path scene = f.scratch / "gi-scene.json";
    std::ofstream(scene) << R"({"version": 1,
      "objects": [{"mesh": "cube.obj", "transform": {"translation": [-0.05, 0, -0.3], "scale": 0.2}}],
      "lights": [{"type": "point", "position": [0.3, 0.2, 1.0], "power": 5}],
      "gi": {"technique": "lightskin", "backend": "gl", "sparsePoints": 64, "valStride": 2}})";
    const auto replay = [&](const std::string& view) {
        const fs::path out = f.scratch / ("out-" + view);
        const CliRun r = runCli("replay " + f.recording.string() + " --scene " + scene.string() + " --out " +
                                    out.string() + " --max-frames 1 --no-video --view " + view,
                                f.scratch);
        EXPECT_EQ(r.exitCode, 0) << r.err;
        return out;
    };
    const fs::path vals = replay("vals");
    const nlohmann::json report = nlohmann::json::parse(test::readText(vals / "report.json"));
    EXPECT_EQ(report["compareLabels"], nlohmann::json({"VALs by flux over the composite", "composite without GI"}));
    EXPECT_EQ(report["frames"][0]["compareImage"], "compare-vals/000000.png");
    EXPECT_TRUE(fs::exists(vals / "compare-vals" / "000000.png")) << listing(vals);
    EXPECT_FALSE(fs::exists(vals / "compare")) << listing(vals);
    const std::string md = test::readText(vals / "report.md");
    EXPECT_EQ(md.find("With GI"), std::string::npos) << md;
    EXPECT_EQ(md.find("with GI"), std::string::npos) << md;
    EXPECT_NE(md.find("## The VALs by flux drawn over the composite / the composite without GI"), std::string::npos)
        << md;
    // The final view keeps the paper's wording, in compare/.
    const fs::path final = replay("final");
    const nlohmann::json finalReport = nlohmann::json::parse(test::readText(final / "report.json"));
    EXPECT_EQ(finalReport["compareLabels"], nlohmann::json({"with GI (lightskin)", "without GI"}));
    EXPECT_EQ(finalReport["frames"][0]["compareImage"], "compare/000000.png");
    EXPECT_NE(test::readText(final / "report.md").find("## With GI / without GI"), std::string::npos);
}

// Point 7: a live snapshot is the rendered image without the status line burnt in. The recording is
// one flat colour and the scene's only object is behind the camera (world z towards the camera, camera
// at z = 1 m): the composite is the camera image, so every pixel of the snapshot must be that colour;
// the status line's white-on-black text would change hundreds of pixels in the bottom rows.
TEST(Cli, LiveSnapshotHasNoStatusLine) {
    const Fixture f("cli_live_snapshot");
    const fs::path scene = f.scratch / "behind.json", snapshot = f.scratch / "snapshot.png";
    std::ofstream(scene) << R"({"version": 1,
      "objects": [{"mesh": "cube.obj", "transform": {"translation": [0, 0, 3], "scale": 0.2}}],
      "lights": [{"type": "point", "position": [0.3, 0.2, 1.0], "power": 5}], "gi": {"technique": "none"}})";
    const CliRun r =
        runCli("live --headless --fast --pose ground-truth --max-frames 3 --snapshot-after 1 --device " +
                   f.recording.string() + " --scene " + scene.string() + " --snapshot " + snapshot.string(),
               f.scratch);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find("live: frame 1:"), std::string::npos) << "the status line exists: " << r.err;
    const cv::Mat image = cv::imread(snapshot.string(), cv::IMREAD_COLOR);
    ASSERT_EQ(image.size(), cv::Size(test::kWallWidth, test::kWallHeight));
    cv::Mat differs;
    cv::absdiff(image, cv::Scalar(40, 90, 160), differs);
    // 8-bit camera colour composited unchanged: at most 1 level of rounding through linear light.
    double largest = 0.0;
    cv::minMaxLoc(differs.reshape(1), nullptr, &largest);
    EXPECT_LE(largest, 1.0);
}

// A new user's walk: bad values are named with the option and what was expected; words from a
// fixed list are checked while the command line is parsed (exit 64, before the scene or GL is touched).
TEST(Cli, BadOptionValuesNameTheOptionAndWhatWasExpected) {
    const Fixture f("cli_bad_values");
    const fs::path out = f.scratch / "out";
    const auto refused = [&](const std::string& arguments, int code, const std::string& says) {
        SCOPED_TRACE(arguments);
        const CliRun r = runCli(arguments, f.scratch);
        EXPECT_EQ(r.exitCode, code);
        expectOneErrorLine(r, says);
        EXPECT_EQ(r.err.find("[info] OpenGL context"), std::string::npos) << "found only after GL started: " << r.err;
        EXPECT_EQ(r.out, "");
        EXPECT_FALSE(fs::exists(out)) << listing(out);
    };
    refused(f.replay(out, "--pose bogus"), 64, "--pose: expected one of: ground-truth, tracking, fixed; got 'bogus'");
    refused(f.replay(out, "--view bogus"), 64, "--view: expected one of: final, direct, indirect");
    refused(f.replay(out, "--backend gpu"), 64, "--backend: expected one of: auto, gl, cpu; got 'gpu'");
    refused("live --headless --device " + f.recording.string() + " --scene " + f.scene.string() + " --pose x", 64,
            "--pose: expected one of: ground-truth, tracking, fixed; got 'x'");
    refused(f.replay(out, "--write-frames 5-2"), 64, "--write-frames: the range '5-2' runs backwards; write it as 2-5");
    refused("track --tag-id 0 --tag-size -1 x.png", 64, "--tag-size: expected a number in [0.0001, 100], got '-1'");
    refused("track --tag-size 0.1 x.png", 64, "--tag-size requires --tag-id");
    const fs::path file = f.scratch / "a-file";
    std::ofstream(file) << "x";
    refused("doctor --out " + (file / "triangle.png").string(), 1, file.string() + ": is not a folder");
    refused("doctor --out " + f.scratch.string(), 1, "is a folder (--out needs a file name)");
}

// Point 7: a bad index line is reported with its line in the file (the JSON parser counts from 1 on
// every line it is given), before anything is written.
TEST(Cli, ABadIndexLineIsNamedByItsLineInTheFile) {
    const Fixture f("cli_index_line");
    const fs::path index = f.recording / "frames.jsonl";
    std::vector<std::string> lines;
    {
        std::ifstream in(index);
        for (std::string line; std::getline(in, line);) lines.push_back(line);
    }
    ASSERT_GE(lines.size(), 3u);
    lines[2] = "{\"frame\": 2, oops";
    {
        std::ofstream file(index, std::ios::trunc);
        for (const std::string& line : lines) file << line << "\n";
    }
    const fs::path out = f.scratch / "out";
    const CliRun r = runCli(f.replay(out), f.scratch);
    EXPECT_EQ(r.exitCode, 1);
    expectOneErrorLine(r, "line 3: malformed index line");
    EXPECT_EQ(r.errLines().back().find("at line 1,"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
}

// docs/CLI.md holds every command's --help as the program prints it, so it cannot go stale:
// LIGHTSKIN_UPDATE_CLI_DOC=1 rewrites the section (scripts/update-cli-doc.sh), else it is compared.
TEST(Cli, DocsListEveryCommandAsTheProgramDoes) {
    const fs::path scratch = test::scratchDir("cli_doc");
    const CliRun top = runCli("--help", scratch);
    ASSERT_EQ(top.exitCode, 0);
    std::vector<std::string> commands;
    {
        std::istringstream lines(top.out);
        bool inList = false;
        for (std::string line; std::getline(lines, line);) {
            if (line.rfind("Subcommands:", 0) == 0)
                inList = true;
            else if (inList && line.rfind("  ", 0) == 0)
                commands.push_back(line.substr(2, line.find(' ', 2) - 2));
        }
    }
    ASSERT_GE(commands.size(), 16u) << top.out; // the 16 commands of docs/CLI.md's table at least
    const auto normalised = [&](std::string help) {
        // "Usage: /path/to/build/apps/lightskin replay ..." -> "Usage: lightskin replay ..."
        const std::string path = program();
        for (std::size_t at; (at = help.find(path)) != std::string::npos;) help.replace(at, path.size(), "lightskin");
        return help;
    };
    std::string generated =
        "<!-- cli-help:begin (generated: scripts/update-cli-doc.sh) -->\n\n### lightskin\n\n```text\n" +
        normalised(top.out) + "```\n";
    for (const std::string& command : commands) {
        const CliRun help = runCli(command + " --help", scratch);
        ASSERT_EQ(help.exitCode, 0) << command;
        generated += "\n### lightskin " + command + "\n\n```text\n" + normalised(help.out) + "```\n";
    }
    generated += "\n<!-- cli-help:end -->\n";

    const fs::path doc = test::sourceDir() / "docs" / "CLI.md";
    std::string text = test::readText(doc);
    const std::size_t begin = text.find("<!-- cli-help:begin"), end = text.find("<!-- cli-help:end -->");
    ASSERT_NE(begin, std::string::npos) << doc;
    ASSERT_NE(end, std::string::npos) << doc;
    const std::string current = text.substr(begin, end + std::strlen("<!-- cli-help:end -->\n") - begin);
    if (std::getenv("LIGHTSKIN_UPDATE_CLI_DOC") != nullptr) {
        text.replace(begin, current.size(), generated);
        std::ofstream(doc) << text;
        return;
    }
    EXPECT_EQ(current, generated) << "docs/CLI.md is out of date: run scripts/update-cli-doc.sh";
}
