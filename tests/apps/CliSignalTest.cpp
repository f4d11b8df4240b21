// Signals leave a report: SIGINT (once or twice) and SIGTERM in the long-running commands stop after
// the current frame, close the video, finish the recording and write the report marked interrupted,
// and exit 128 + the signal (130, 143). Each run is signalled at a random moment (seeded, so a failure
// can be repeated) after its first frame was written, and must end within a bound. The bench* commands
// stop after the current measurement: their JSON says "status": "interrupted", their stdout ends with
// a line saying so after the results measured before the stop.
#include "CliRun.h"
#include "TestPaths.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/videoio.hpp>

#include <chrono>
#include <csignal>
#include <fcntl.h>
#include <functional>
#include <random>
#include <sstream>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

using namespace lightskin;
using namespace lightskin::test::cli;
namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

struct SignalPlan {
    int signal = SIGINT;
    int times = 1; ///< 2: a second one 20 ms after the first
};

/// Starts `lightskin <arguments>` in `cwd` (stdout, stderr into files there), waits until `ready()`,
/// then a random 0-300 ms, sends the signal(s) and returns the exit code (-1: killed by a signal or
/// still running after 120 s, then SIGKILLed).
int runAndSignal(const std::string& arguments, const fs::path& cwd, const std::function<bool()>& ready, SignalPlan plan,
                 std::mt19937& random) {
    const std::string command = "exec " + program() + " " + arguments + " > " + (cwd / "stdout.txt").string() + " 2> " +
                                (cwd / "stderr.txt").string() + " < /dev/null";
    const pid_t pid = ::fork();
    if (pid == 0) {
        if (::chdir(cwd.c_str()) != 0) ::_exit(127);
        ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
        ::_exit(127);
    }
    const auto deadline = Clock::now() + std::chrono::seconds(120);
    int status = 0;
    bool exited = false;
    while (!ready() && Clock::now() < deadline && !exited) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        exited = ::waitpid(pid, &status, WNOHANG) == pid;
    }
    if (exited) {
        ADD_FAILURE() << "ended before it could be signalled: " << arguments;
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(std::uniform_int_distribution<int>(0, 300)(random)));
    for (int i = 0; i < plan.times; ++i) {
        ::kill(pid, plan.signal);
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    while (Clock::now() < deadline) {
        if (::waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
    ADD_FAILURE() << "still running 120 s after the signal: " << arguments;
    return -1;
}

/// runAndSignal once `ready` exists (the first frame the command wrote).
int runAndSignal(const std::string& arguments, const fs::path& cwd, const fs::path& ready, SignalPlan plan,
                 std::mt19937& random) {
    return runAndSignal(arguments, cwd, [&ready] { return fs::exists(ready); }, plan, random);
}

const std::vector<SignalPlan> kPlans = {{SIGINT, 1}, {SIGINT, 2}, {SIGTERM, 1}};

std::size_t filesIn(const fs::path& folder, const std::string& extension) {
    std::size_t n = 0;
    if (fs::is_directory(folder))
        for (const auto& entry : fs::directory_iterator(folder)) n += entry.path().extension() == extension ? 1u : 0u;
    return n;
}

/// A finished lightskin recording: its index ends with the end marker, and `lightskin info` reads it.
void expectFinishedRecording(const fs::path& folder, const fs::path& scratch) {
    const std::string index = test::readText(folder / "frames.jsonl");
    EXPECT_NE(index.find("\"end\":true"), std::string::npos)
        << index.substr(index.size() > 300 ? index.size() - 300 : 0);
    EXPECT_EQ(runCli("info " + folder.string(), scratch).exitCode, 0);
}

/// How often `what` occurs in `text` (result lines a bench printed).
std::size_t occurrences(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
    return n;
}

std::string lastLine(const std::string& text) {
    std::istringstream lines(text);
    std::string last;
    for (std::string line; std::getline(lines, line);)
        if (!line.empty()) last = line;
    return last;
}

/// Ready once the program's stdout holds `text`: how far a bench that prints as it measures got.
std::function<bool()> stdoutHolds(const fs::path& scratch, const std::string& text) {
    return [file = scratch / "stdout.txt", text] { return test::readText(file).find(text) != std::string::npos; };
}

/// A stopped bench: exit 128 + the signal, and its stdout (returned) ends with the line saying it stopped,
/// after the results measured before the stop.
std::string expectInterruptedBench(int code, SignalPlan plan, const fs::path& scratch, const std::string& bench) {
    EXPECT_EQ(code, 128 + plan.signal) << test::readText(scratch / "stderr.txt");
    const std::string out = test::readText(scratch / "stdout.txt");
    EXPECT_EQ(lastLine(out), bench + ": interrupted; the results above are those measured before the stop") << out;
    return out;
}

/// A stopped bench's JSON: whole (it parses) and marked interrupted.
nlohmann::json interruptedJson(const fs::path& file) {
    nlohmann::json json;
    EXPECT_NO_THROW(json = nlohmann::json::parse(test::readText(file))) << file;
    EXPECT_EQ(json.value("status", std::string()), "interrupted") << file;
    return json;
}

} // namespace

TEST(CliSignal, ReplayWritesAnInterruptedReportAndAPlayableVideo) {
    const fs::path scratch = test::scratchDir("cli_signal_replay");
    const fs::path orbit = test::sourceDir() / "recordings" / "synth-orbit";
    const fs::path scene = test::sourceDir() / "recordings" / "scenes" / "orbit.json";
    std::mt19937 random(31);
    for (const SignalPlan& plan : kPlans) {
        const fs::path out = scratch / ("out-" + std::to_string(plan.signal) + "-" + std::to_string(plan.times));
        SCOPED_TRACE(out.filename().string());
        const int code = runAndSignal("replay " + orbit.string() + " --scene " + scene.string() + " --out " +
                                          out.string() + " --no-compare",
                                      scratch, out / "frames" / "000000.png", plan, random);
        EXPECT_EQ(code, 128 + plan.signal) << test::readText(scratch / "stderr.txt");
        const nlohmann::json report = nlohmann::json::parse(test::readText(out / "report.json"));
        EXPECT_EQ(report["status"], "interrupted");
        const std::size_t frames = report["frames"].size();
        EXPECT_GE(frames, 1u);
        EXPECT_LT(frames, 40u) << "not interrupted";
        EXPECT_EQ(filesIn(out / "frames", ".png"), frames);
        // The video holds every frame of the report: finalised, not cut off.
        cv::VideoCapture video((out / report["video"].get<std::string>()).string());
        ASSERT_TRUE(video.isOpened());
        std::size_t decoded = 0;
        for (cv::Mat image; video.read(image);) ++decoded;
        EXPECT_EQ(decoded, frames);
    }
}

TEST(CliSignal, RecordFinishesTheRecording) {
    const fs::path scratch = test::scratchDir("cli_signal_record");
    const fs::path orbit = test::sourceDir() / "recordings" / "synth-orbit";
    std::mt19937 random(32);
    for (const SignalPlan& plan : kPlans) {
        const fs::path out = scratch / ("out-" + std::to_string(plan.signal) + "-" + std::to_string(plan.times));
        SCOPED_TRACE(out.filename().string());
        const int code = runAndSignal("record --realtime --source " + orbit.string() + " --out " + out.string(),
                                      scratch, out / "colour" / "000000.png", plan, random);
        EXPECT_EQ(code, 128 + plan.signal) << test::readText(scratch / "stderr.txt");
        expectFinishedRecording(out, scratch);
    }
}

TEST(CliSignal, LiveFinishesItsRecording) {
    const fs::path scratch = test::scratchDir("cli_signal_live");
    const fs::path orbit = test::sourceDir() / "recordings" / "synth-orbit";
    const fs::path scene = test::sourceDir() / "recordings" / "scenes" / "orbit.json";
    std::mt19937 random(33);
    for (const SignalPlan& plan : kPlans) {
        const fs::path out = scratch / ("rec-" + std::to_string(plan.signal) + "-" + std::to_string(plan.times));
        SCOPED_TRACE(out.filename().string());
        const int code = runAndSignal("live --headless --device " + orbit.string() + " --scene " + scene.string() +
                                          " --record " + out.string(),
                                      scratch, out / "colour" / "000000.png", plan, random);
        EXPECT_EQ(code, 128 + plan.signal) << test::readText(scratch / "stderr.txt");
        expectFinishedRecording(out, scratch);
    }
}

TEST(CliSignal, SynthFinishesTheRecording) {
    const fs::path scratch = test::scratchDir("cli_signal_synth");
    const fs::path description = test::sourceDir() / "recordings" / "scenes-synth" / "orbit.json";
    std::mt19937 random(34);
    for (const SignalPlan& plan : kPlans) {
        const fs::path out = scratch / ("out-" + std::to_string(plan.signal) + "-" + std::to_string(plan.times));
        SCOPED_TRACE(out.filename().string());
        const int code = runAndSignal("synth " + description.string() + " --out " + out.string(), scratch,
                                      out / "colour" / "000000.png", plan, random);
        EXPECT_EQ(code, 128 + plan.signal) << test::readText(scratch / "stderr.txt");
        expectFinishedRecording(out, scratch);
    }
}

// Across the bench tests each plan appears: SIGINT once, SIGINT twice, SIGTERM. The options keep each run a
// few seconds long, well beyond the signal's 300 ms, so it is always signalled while measuring.

TEST(CliSignal, BenchWritesAnInterruptedReport) {
    const fs::path scratch = test::scratchDir("cli_signal_bench");
    const fs::path out = scratch / "out";
    std::mt19937 random(41);
    const SignalPlan plan{SIGINT, 1};
    const int code = runAndSignal("bench --quick --no-temporal --out " + out.string(), scratch,
                                  stdoutHolds(scratch, "[1/"), plan, random);
    const std::string printed = expectInterruptedBench(code, plan, scratch, "bench");
    const nlohmann::json report = interruptedJson(out / "bench.json");
    // The configuration running at the stop was finished, no other started; every one measured is in the report
    // (the default one adds the brute force's row).
    const std::size_t measured = occurrences(printed, " px: GPU ");
    EXPECT_GE(measured, 1u);
    EXPECT_EQ(occurrences(printed, "[" + std::to_string(measured + 1) + "/"), 0u) << printed;
    EXPECT_LT(measured, std::stoul(printed.substr(printed.rfind('\n', printed.find(" configurations")) + 1)))
        << "not interrupted";
    EXPECT_GE(report["runs"].size(), measured);
    EXPECT_LE(report["runs"].size(), measured + 1);
    EXPECT_NE(test::readText(out / "bench.md").find("(interrupted"), std::string::npos);
    EXPECT_TRUE(report["checks"].empty()) << "the checks need the whole sweep";
}

TEST(CliSignal, BenchCpuWritesAnInterruptedJson) {
    const fs::path scratch = test::scratchDir("cli_signal_bench_cpu");
    const fs::path out = scratch / "out";
    std::mt19937 random(42);
    const SignalPlan plan{SIGTERM, 1};
    const int code = runAndSignal("bench-cpu --width 160 --height 120 --vals 80x60,160x120,320x240 --repeat 2 --out " +
                                      out.string(),
                                  scratch, stdoutHolds(scratch, "GL (llvmpipe)"), plan, random);
    const std::string printed = expectInterruptedBench(code, plan, scratch, "bench-cpu");
    const nlohmann::json report = interruptedJson(out / "bench-cpu.json");
    EXPECT_EQ(report["runs"].size(), occurrences(printed, " ms CPU |")); // one row per timing printed
    EXPECT_GE(report["runs"].size(), 1u);
}

TEST(CliSignal, BenchCullPrintsTheRowsMeasured) {
    const fs::path scratch = test::scratchDir("cli_signal_bench_cull");
    std::mt19937 random(43);
    const SignalPlan plan{SIGINT, 2};
    const int code = runAndSignal("bench-cull --vals 4096,16384,65536,262144,524288,1048576 --repeat 3", scratch,
                                  stdoutHolds(scratch, "|---|"), plan, random);
    const std::string printed = expectInterruptedBench(code, plan, scratch, "bench-cull");
    EXPECT_EQ(occurrences(printed, "\n| 1048576 |"), 0u) << "not interrupted";
}

TEST(CliSignal, BenchEmbedPrintsTheFramesMeasured) {
    const fs::path scratch = test::scratchDir("cli_signal_bench_embed");
    std::mt19937 random(44);
    const SignalPlan plan{SIGTERM, 1};
    const int code = runAndSignal("bench-embed --frames 40 --warm-up 2 --budgets 400 150", scratch,
                                  stdoutHolds(scratch, "bench-embed:"), plan, random);
    expectInterruptedBench(code, plan, scratch, "bench-embed");
}

TEST(CliSignal, BenchGatherWritesAnInterruptedJson) {
    const fs::path scratch = test::scratchDir("cli_signal_bench_gather");
    const fs::path out = scratch / "out";
    std::mt19937 random(45);
    const SignalPlan plan{SIGINT, 1};
    const int code = runAndSignal("bench-gather --no-brute --width 160 --height 120 --vals 80x60,160x120,320x240 "
                                  "--sparse 256,1024 --repeat 2 --out " +
                                      out.string(),
                                  scratch, stdoutHolds(scratch, "covered pixels"), plan, random);
    const std::string printed = expectInterruptedBench(code, plan, scratch, "bench-gather");
    const nlohmann::json report = interruptedJson(out / "bench-gather.json");
    EXPECT_EQ(report["runs"].size(), occurrences(printed, " total ")); // one row per setup printed
}

TEST(CliSignal, BenchLightsWritesTheRowsMeasured) {
    const fs::path scratch = test::scratchDir("cli_signal_bench_lights");
    const fs::path table = scratch / "lights.md";
    std::mt19937 random(46);
    const SignalPlan plan{SIGINT, 2};
    const int code =
        runAndSignal("bench-lights --repeat 3 --out " + table.string(), scratch, stdoutHolds(scratch, "Renderer:"),
                     plan, random);
    const std::string printed = expectInterruptedBench(code, plan, scratch, "bench-lights");
    EXPECT_EQ(test::readText(table), printed); // the file holds what was printed, the stop included
}

TEST(CliSignal, BenchRealDepthWritesAnInterruptedReport) {
    const fs::path scratch = test::scratchDir("cli_signal_bench_realdepth");
    const fs::path out = scratch / "out";
    std::mt19937 random(47);
    const SignalPlan plan{SIGTERM, 1};
    const int code = runAndSignal(
        "bench-realdepth --recordings icl-nuim --models old,robust --sink 0 --out " + out.string(), scratch,
        [first = out / "images" / "icl-nuim_old_sink0mm_lightskin.png"] { return fs::exists(first); }, plan, random);
    expectInterruptedBench(code, plan, scratch, "bench-realdepth");
    const nlohmann::json report = interruptedJson(out / "bench-realdepth.json");
    EXPECT_EQ(report["bench"], "bench-realdepth");
    const std::string table = test::readText(out / "realdepth.md");
    EXPECT_GE(occurrences(table, "\n| icl-nuim |"), 1u) << table; // the case stopped keeps its frames
    EXPECT_NE(table.find("bench-realdepth: interrupted"), std::string::npos);
}

TEST(CliSignal, BenchStaticPrintsTheStreamsMeasured) {
    const fs::path scratch = test::scratchDir("cli_signal_bench_static");
    std::mt19937 random(48);
    const SignalPlan plan{SIGINT, 1};
    const int code = runAndSignal("bench-static --frames 30 --width 160 --height 120 --tolerances 0.1", scratch,
                                  stdoutHolds(scratch, "## lightskin bench-static"), plan, random);
    expectInterruptedBench(code, plan, scratch, "bench-static");
}
