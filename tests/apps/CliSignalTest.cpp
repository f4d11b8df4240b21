// Signals leave a report: SIGINT (once or twice) and SIGTERM in the long-running commands stop after
// the current frame, close the video, finish the recording and write the report marked interrupted,
// and exit 128 + the signal (130, 143). Each run is signalled at a random moment (seeded, so a failure
// can be repeated) after its first frame was written, and must end within a bound.
#include "CliRun.h"
#include "TestPaths.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/videoio.hpp>

#include <chrono>
#include <csignal>
#include <fcntl.h>
#include <random>
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

/// Starts `lightskin <arguments>` in `cwd` (stdout, stderr into files there), waits until `ready`
/// exists, then a random 0-300 ms, sends the signal(s) and returns the exit code (-1: killed by a
/// signal or still running after 120 s, then SIGKILLed).
int runAndSignal(const std::string& arguments, const fs::path& cwd, const fs::path& ready, SignalPlan plan,
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
    while (!fs::exists(ready) && Clock::now() < deadline && !exited) {
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
