// Recorder: bounded queue, every frame written or counted, and the `lightskin record` process
// stopped by Ctrl-C (SIGINT) or killed (SIGKILL) leaves a readable recording.
#include "CaptureTestUtil.h"
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/capture/Recorder.h>
#include <lightskin/capture/Recording.h>
#include <lightskin/capture/Registration.h>

#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <signal.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace lightskin::test {
namespace {

TEST(RecorderTest, EveryFrameIsWrittenOrCountedAsDropped) {
    const auto folder = scratchDir("recorder_queue") / "rec";
    const auto info = smallRecordingInfo(320, 240);
    auto recorder =
        capture::Recorder::start(capture::RecordingWriter::create(folder, info), capture::RecorderOptions{2});
    std::vector<std::uint32_t> accepted;
    RgbdFrame frame = syntheticFrame(info, 0);
    for (std::uint32_t i = 0; i < 40; ++i) {
        frame = syntheticFrame(info, i); // random 320x240 frames take the writer ~ms each: the queue overflows
        if (recorder->push(frame)) accepted.push_back(i);
    }
    const auto stats = recorder->finish();
    EXPECT_EQ(stats.pushed, 40);
    EXPECT_EQ(stats.written + stats.dropped, 40);
    EXPECT_EQ(stats.written, std::int64_t(accepted.size()));
    EXPECT_GT(stats.dropped, 0) << "a 2-slot queue fed without pause must overflow";
    EXPECT_TRUE(stats.firstError.empty());

    auto source = capture::openFrameSource(folder.string());
    ASSERT_EQ(source->frameCount(), stats.written);
    RgbdFrame read;
    for (std::uint32_t expected : accepted) {
        ASSERT_TRUE(source->next(read));
        const RgbdFrame original = syntheticFrame(info, expected);
        EXPECT_TRUE(identical(read.depth, original.depth)) << "frame " << expected;
        EXPECT_TRUE(identical(read.colour, original.colour)) << "frame " << expected;
    }
    EXPECT_TRUE(capture::readRecordingSummary(folder).finished);
}

TEST(RecorderTest, WriteFailuresAreCountedAsDroppedAndReported) {
    const auto folder = scratchDir("recorder_write_error") / "rec";
    const auto info = smallRecordingInfo(64, 48);
    auto writer = capture::RecordingWriter::create(folder, info);
    // A folder where frame 3's depth file must go: the rename fails (even for root).
    std::filesystem::create_directory(folder / "depth" / "000003.png");
    auto recorder = capture::Recorder::start(std::move(writer), capture::RecorderOptions{64});
    for (std::uint32_t i = 0; i < 6; ++i) EXPECT_TRUE(recorder->push(syntheticFrame(info, i)));
    const auto stats = recorder->finish();
    EXPECT_EQ(stats.written, 3);
    EXPECT_EQ(stats.dropped, 3); // frame 3 and, numbered 3 again, every frame after it
    EXPECT_NE(stats.firstError.find("000003.png"), std::string::npos) << stats.firstError;
    EXPECT_EQ(capture::openFrameSource(folder.string())->frameCount(), 3);
}

TEST(RecorderTest, LargeQueueDropsNothing) {
    const auto folder = scratchDir("recorder_nodrop") / "rec";
    const auto info = smallRecordingInfo(64, 48);
    auto recorder =
        capture::Recorder::start(capture::RecordingWriter::create(folder, info), capture::RecorderOptions{64});
    for (std::uint32_t i = 0; i < 50; ++i) EXPECT_TRUE(recorder->push(syntheticFrame(info, i)));
    const auto stats = recorder->finish();
    EXPECT_EQ(stats.written, 50);
    EXPECT_EQ(stats.dropped, 0);
}

/// A 300-frame 30 fps recording (10 s when replayed in real time).
std::filesystem::path makeLongSource(const std::string& name) {
    const auto folder = scratchDir(name) / "source";
    const auto info = smallRecordingInfo(80, 60);
    auto writer = capture::RecordingWriter::create(folder, info);
    for (std::uint32_t i = 0; i < 300; ++i) writer.write(syntheticFrame(info, i));
    return folder;
}

std::int64_t completeIndexLines(const std::filesystem::path& folder) {
    std::ifstream index(folder / capture::kRecordingIndexFile);
    std::string line;
    std::int64_t lines = 0;
    while (std::getline(index, line)) ++lines;
    return lines;
}

/// Starts `lightskin record --realtime` and sends `signal` once at least 5 frames are recorded.
int recordAndSignal(const std::filesystem::path& source, const std::filesystem::path& out, int signal) {
    const pid_t child = fork();
    if (child == 0) {
        const std::string src = source.string(), dst = out.string();
        execl(LIGHTSKIN_CLI, LIGHTSKIN_CLI, "--quiet", "record", "--source", src.c_str(), "--out", dst.c_str(),
              "--realtime", static_cast<char*>(nullptr));
        _exit(127);
    }
    EXPECT_GT(child, 0);
    // A hang guard, not a timing claim: the loop ends as soon as 5 frames are on disk (~0.2 s of
    // recording at 30 fps; a loaded machine may take seconds to start the child), so a long limit
    // costs nothing when the recorder works.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (completeIndexLines(out) < 5 && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    kill(child, signal);
    int status = 0;
    waitpid(child, &status, 0);
    return status;
}

void expectFramesMatchSource(const std::filesystem::path& recorded, const std::filesystem::path& source) {
    auto replay = capture::openFrameSource(recorded.string());
    auto original = capture::openFrameSource(source.string());
    ASSERT_GE(replay->frameCount().value_or(0), 5);
    ASSERT_LT(replay->frameCount().value_or(300), 300) << "the signal must have stopped the recorder early";
    RgbdFrame a, b;
    while (replay->next(a)) {
        ASSERT_TRUE(original->next(b));
        EXPECT_TRUE(identical(a.depth, b.depth)) << "frame " << a.index;
        EXPECT_TRUE(identical(a.colour, b.colour)) << "frame " << a.index;
        EXPECT_EQ(a.depthTimestampSeconds, b.depthTimestampSeconds);
    }
}

TEST(RecorderTest, SigkilledRecorderLeavesEveryCompletedFrameReadable) {
    const auto source = makeLongSource("recorder_sigkill");
    const auto out = source.parent_path() / "out";
    const int status = recordAndSignal(source, out, SIGKILL);
    ASSERT_TRUE(WIFSIGNALED(status));
    EXPECT_EQ(WTERMSIG(status), SIGKILL);
    EXPECT_FALSE(capture::readRecordingSummary(out).finished);
    expectFramesMatchSource(out, source);
}

TEST(RecorderTest, CtrlCFinishesTheRecordingCleanly) {
    const auto source = makeLongSource("recorder_sigint");
    const auto out = source.parent_path() / "out";
    const int status = recordAndSignal(source, out, SIGINT);
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 130); // 128 + SIGINT, as docs/CLI.md says, after finishing the recording
    EXPECT_TRUE(capture::readRecordingSummary(out).finished);
    expectFramesMatchSource(out, source);
}

TEST(RecorderTest, RecordCommandRoundTripIsBitExact) {
    const auto scratch = scratchDir("recorder_cli_roundtrip");
    const auto info = smallRecordingInfo(64, 48);
    {
        auto writer = capture::RecordingWriter::create(scratch / "source", info);
        for (std::uint32_t i = 0; i < 10; ++i) writer.write(syntheticFrame(info, i));
    }
    const std::string command = std::string(LIGHTSKIN_CLI) + " --quiet record --source " +
                                (scratch / "source").string() + " --out " + (scratch / "copy").string() +
                                " > /dev/null";
    ASSERT_EQ(std::system(command.c_str()), 0);
    auto copy = capture::openFrameSource((scratch / "copy").string());
    EXPECT_EQ(copy->frameCount(), 10);
    EXPECT_EQ(copy->info().colourIntrinsics.distortion, info.colourIntrinsics.distortion);
    RgbdFrame frame;
    for (std::uint32_t i = 0; copy->next(frame); ++i) {
        EXPECT_TRUE(identical(frame.depth, syntheticFrame(info, i).depth));
        EXPECT_TRUE(identical(frame.colour, syntheticFrame(info, i).colour));
    }
}

TEST(RecorderTest, InfoCommandDescribesARecording) {
    const auto scratch = scratchDir("recorder_cli_info");
    const auto info = smallRecordingInfo(64, 48);
    {
        auto writer = capture::RecordingWriter::create(scratch / "rec", info);
        for (std::uint32_t i = 0; i < 4; ++i) {
            RgbdFrame frame = syntheticFrame(info, i);
            if (i == 2) frame.groundTruth_world_T_camera = Pose();
            writer.write(frame);
        }
    }
    const std::string command =
        std::string(LIGHTSKIN_CLI) + " info " + (scratch / "rec").string() + " > " + (scratch / "info.txt").string();
    ASSERT_EQ(std::system(command.c_str()), 0);
    std::ifstream in(scratch / "info.txt");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("format version 1"), std::string::npos) << text;
    EXPECT_NE(text.find("synthetic test camera"), std::string::npos) << text;
    EXPECT_NE(text.find("frames:        4 (4 with colour, 4 with depth, 1 with ground-truth pose)"), std::string::npos)
        << text;
    EXPECT_NE(text.find("64x48 fx=30.000"), std::string::npos) << text;
    EXPECT_NE(text.find("state:         finished"), std::string::npos) << text;
}

// An unregistered source: `record` keeps its depth and stores its extrinsic (info prints it), or
// with --register-depth writes the depth registered to colour exactly as DepthRegistrar does.
TEST(RecorderTest, RecordCommandStoresTheExtrinsicOrRegistersTheDepth) {
    const auto scratch = scratchDir("recorder_cli_registration");
    auto info = smallRecordingInfo(64, 48);
    info.registration = DepthRegistration::Unregistered;
    info.depthIntrinsics.fx = info.depthIntrinsics.fy = 36.0; // a depth camera narrower than the colour one
    info.colour_T_depth = Pose(glm::dquat(1.0, 0.0, 0.0, 0.0), glm::dvec3(0.025, 0.001, -0.002));
    {
        auto writer = capture::RecordingWriter::create(scratch / "source", info);
        for (std::uint32_t i = 0; i < 3; ++i) writer.write(syntheticFrame(info, i));
    }
    const std::string source = (scratch / "source").string();
    ASSERT_EQ(std::system((std::string(LIGHTSKIN_CLI) + " --quiet record --source " + source + " --out " +
                           (scratch / "raw").string() + " > /dev/null")
                              .c_str()),
              0);
    ASSERT_EQ(std::system((std::string(LIGHTSKIN_CLI) + " --quiet record --register-depth --source " + source +
                           " --out " + (scratch / "registered").string() + " > /dev/null")
                              .c_str()),
              0);
    capture::FrameSourceOptions asStored;
    asStored.softwareRegistration = false;
    auto raw = capture::openFrameSource((scratch / "raw").string(), asStored);
    EXPECT_EQ(raw->info().registration, DepthRegistration::Unregistered);
    EXPECT_EQ(raw->info().colour_T_depth.translation(), info.colour_T_depth.translation());
    auto registered = capture::openFrameSource((scratch / "registered").string(), asStored);
    EXPECT_EQ(registered->info().registration, DepthRegistration::RegisteredToColour);
    EXPECT_EQ(registered->info().depthIntrinsics.fx, info.colourIntrinsics.fx);

    const auto registrar =
        capture::DepthRegistrar::create({info.depthIntrinsics, info.colourIntrinsics, info.colour_T_depth, "test"});
    RgbdFrame frame;
    cv::Mat expected;
    std::uint32_t frames = 0;
    for (; registered->next(frame); ++frames) {
        registrar.registerInto(syntheticFrame(info, frames).depth, info.depthScaleMetres, expected);
        EXPECT_TRUE(identical(frame.depth, expected)) << "frame " << frames;
        EXPECT_GT(cv::countNonZero(frame.depth), 0);
    }
    EXPECT_EQ(frames, 3u);

    const std::string command =
        std::string(LIGHTSKIN_CLI) + " info " + (scratch / "raw").string() + " > " + (scratch / "info.txt").string();
    ASSERT_EQ(std::system(command.c_str()), 0);
    std::ifstream in(scratch / "info.txt");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("registration:  unregistered"), std::string::npos) << text;
    EXPECT_NE(text.find("colour_T_depth: t = (0.0250, 0.0010, -0.0020) m, rotation 0.000 deg"), std::string::npos)
        << text;
}

} // namespace
} // namespace lightskin::test
