#include "CaptureTestUtil.h"
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/capture/Recording.h>
#include <lightskin/core/Error.h>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <fstream>
#include <thread>

namespace lightskin::test {
namespace {

using capture::RecordingWriter;

TEST(RecordingTest, RoundTripIsBitExactWithPosesAndTimestamps) {
    const auto folder = scratchDir("recording_roundtrip") / "rec";
    const auto info = smallRecordingInfo();
    std::vector<RgbdFrame> written;
    {
        auto writer = RecordingWriter::create(folder, info);
        for (std::uint32_t i = 0; i < 5; ++i) {
            RgbdFrame frame = syntheticFrame(info, i);
            if (i % 2 == 0)
                frame.groundTruth_world_T_camera =
                    Pose(glm::normalize(glm::dquat(1.0, 0.1 * i, -0.2, 0.3)), {0.1 * i, -1.0 / 3.0, 2.0});
            writer.write(frame);
            written.push_back(frame.clone());
        }
        EXPECT_EQ(writer.framesWritten(), 5);
        writer.finish();
    }
    auto source = capture::openFrameSource(folder.string());
    EXPECT_EQ(source->info().kind, "lightskin-recording");
    EXPECT_EQ(source->info().deviceName, info.deviceName);
    EXPECT_EQ(source->frameCount(), 5);
    EXPECT_TRUE(source->info().hasGroundTruth);
    EXPECT_EQ(source->info().colourIntrinsics.distortion, info.colourIntrinsics.distortion);
    RgbdFrame frame;
    for (std::size_t i = 0; i < written.size(); ++i) {
        ASSERT_TRUE(source->next(frame));
        EXPECT_EQ(frame.index, std::int64_t(i));
        EXPECT_TRUE(identical(frame.depth, written[i].depth)) << "depth of frame " << i;
        EXPECT_TRUE(identical(frame.colour, written[i].colour)) << "colour of frame " << i;
        EXPECT_EQ(frame.depthTimestampSeconds, written[i].depthTimestampSeconds); // exact: JSON doubles round-trip
        EXPECT_EQ(frame.colourTimestampSeconds, written[i].colourTimestampSeconds);
        ASSERT_EQ(frame.groundTruth_world_T_camera.has_value(), written[i].groundTruth_world_T_camera.has_value());
        if (frame.groundTruth_world_T_camera) {
            EXPECT_LT(
                Pose::translationDistance(*frame.groundTruth_world_T_camera, *written[i].groundTruth_world_T_camera),
                1e-12);
            EXPECT_LT(
                Pose::rotationAngleBetween(*frame.groundTruth_world_T_camera, *written[i].groundTruth_world_T_camera),
                1e-9);
        }
        EXPECT_NO_THROW(frame.validate("roundtrip"));
    }
    EXPECT_FALSE(source->next(frame));
    EXPECT_EQ(source->framesDelivered(), 5);
    EXPECT_EQ(source->framesDropped(), 0);

    source->seek(3);
    ASSERT_TRUE(source->next(frame));
    EXPECT_EQ(frame.index, 3);
    // Steady state reuses the frame's pixel buffers (no allocation per frame).
    const void* depthBuffer = frame.depth.data;
    const void* colourBuffer = frame.colour.data;
    ASSERT_TRUE(source->next(frame));
    EXPECT_EQ(frame.depth.data, depthBuffer);
    EXPECT_EQ(frame.colour.data, colourBuffer);
    source->seek(3);
    ASSERT_TRUE(source->next(frame));
    EXPECT_TRUE(identical(frame.depth, written[3].depth));

    const auto summary = capture::readRecordingSummary(folder);
    EXPECT_EQ(summary.version, capture::kRecordingFormatVersion);
    EXPECT_EQ(summary.frameCount, 5);
    EXPECT_TRUE(summary.finished);
    EXPECT_EQ(summary.framesWithGroundTruth, 3);
}

TEST(RecordingTest, JpegColourIsSmallAndClose) {
    const auto folder = scratchDir("recording_jpeg") / "rec";
    auto info = smallRecordingInfo(64, 48);
    info.jpegColour = true;
    RgbdFrame frame = syntheticFrame(info, 1);
    cv::GaussianBlur(frame.colour, frame.colour, cv::Size(9, 9), 3.0); // JPEG is for smooth images
    {
        auto writer = RecordingWriter::create(folder, info);
        writer.write(frame);
    }
    auto source = capture::openFrameSource(folder.string());
    RgbdFrame read;
    ASSERT_TRUE(source->next(read));
    EXPECT_TRUE(identical(read.depth, frame.depth)); // depth stays lossless
    EXPECT_LT(cv::norm(read.colour, frame.colour, cv::NORM_L1) / double(frame.colour.total() * 3), 3.0);
}

TEST(RecordingTest, LoopingAndCountersAndUnfinishedRecording) {
    const auto folder = scratchDir("recording_loop") / "rec";
    const auto info = smallRecordingInfo();
    auto writer = RecordingWriter::create(folder, info);
    for (std::uint32_t i = 0; i < 3; ++i) writer.write(syntheticFrame(info, i));
    // Not finished but synced (the default batch is 30 frames): the reader must see three frames.
    EXPECT_EQ(writer.framesListed(), 0);
    writer.sync();
    EXPECT_EQ(writer.framesListed(), 3);
    capture::FrameSourceOptions options;
    options.loop = true;
    auto source = capture::openFrameSource(folder.string(), options);
    EXPECT_FALSE(capture::readRecordingSummary(folder).finished);
    RgbdFrame frame;
    std::vector<std::int64_t> indices;
    for (int i = 0; i < 7; ++i) {
        ASSERT_TRUE(source->next(frame));
        indices.push_back(frame.index);
    }
    EXPECT_EQ(indices, (std::vector<std::int64_t>{0, 1, 2, 0, 1, 2, 0}));
    EXPECT_EQ(source->framesDelivered(), 7);
}

TEST(RecordingTest, CutOffIndexReadsUpToTheLastCompleteFrame) {
    const auto folder = scratchDir("recording_cutoff") / "rec";
    const auto info = smallRecordingInfo();
    {
        auto writer = RecordingWriter::create(folder, info);
        for (std::uint32_t i = 0; i < 4; ++i) writer.write(syntheticFrame(info, i));
        // no finish(): the destructor appends the end marker; simulate a crash instead below
    }
    // Simulate a crash during frame 4: a partial index line and a leftover temporary file.
    std::string index;
    {
        std::ifstream in(folder / capture::kRecordingIndexFile);
        std::string line;
        while (std::getline(in, line))
            if (line.find("\"end\"") == std::string::npos) index += line + "\n";
    }
    std::ofstream(folder / capture::kRecordingIndexFile, std::ios::trunc) << index << R"({"frame":4,"colourTi)";
    std::ofstream(folder / "depth" / "000004.png.tmp") << "partial";
    auto source = capture::openFrameSource(folder.string());
    EXPECT_EQ(source->frameCount(), 4);
    RgbdFrame frame;
    int frames = 0;
    while (source->next(frame)) {
        EXPECT_TRUE(identical(frame.depth, syntheticFrame(info, std::uint32_t(frames)).depth));
        ++frames;
    }
    EXPECT_EQ(frames, 4);
    EXPECT_FALSE(capture::readRecordingSummary(folder).finished);
}

TEST(RecordingTest, RealtimePacingHonoursTimestamps) {
    const auto folder = scratchDir("recording_realtime") / "rec";
    const auto info = smallRecordingInfo();
    {
        auto writer = RecordingWriter::create(folder, info);
        for (std::uint32_t i = 0; i < 4; ++i) writer.write(syntheticFrame(info, i)); // 30 fps
    }
    capture::FrameSourceOptions options;
    options.pacing = capture::Pacing::Realtime;
    auto source = capture::openFrameSource(folder.string(), options);
    // Only bounds that load cannot break (how fast pacing runs is not a test's business): both
    // directions below follow from sleep_for blocking *at least* its duration on the monotonic
    // steady_clock, so a loaded machine can only make each interval longer, never shorter.
    RgbdFrame frame;
    const auto start = std::chrono::steady_clock::now();
    while (source->next(frame)) {
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    // A prompt consumer gets every frame, the last one no earlier than three frame periods after
    // the first (the pacing sleeps until each frame is due). 1e-6 s: sleep_for's conversion of a
    // double duration to the clock's nanoseconds may round down by < 1 ns per frame.
    EXPECT_GE(seconds, 3.0 / 30.0 - 1e-6);
    EXPECT_EQ(source->framesDelivered(), 4);
    EXPECT_EQ(source->framesDropped(), 0);

    // A consumer that is far too slow: after >= 250 ms the remaining frames (due at 33, 67 and
    // 100 ms) are >= 150 ms late, beyond the 100 ms tolerance, so all three are skipped, however
    // loaded the machine (a longer sleep only makes them later).
    source->seek(0);
    source->next(frame);
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
    int more = 0;
    while (source->next(frame)) ++more;
    EXPECT_EQ(more, 0);
    EXPECT_EQ(source->framesDropped(), 3);
}

TEST(RecordingTest, WriterRefusesMismatchedFramesAndNonEmptyFolders) {
    const auto folder = scratchDir("recording_refuse") / "rec";
    const auto info = smallRecordingInfo();
    auto writer = RecordingWriter::create(folder, info);
    RgbdFrame frame = syntheticFrame(info, 0);
    frame.depth = cv::Mat(10, 10, CV_16UC1, cv::Scalar(1));
    EXPECT_THROW(writer.write(frame), Error);
    frame = syntheticFrame(info, 0);
    frame.depth.convertTo(frame.depth, CV_32F);
    EXPECT_THROW(writer.write(frame), Error);
    EXPECT_EQ(writer.framesWritten(), 0);
    writer.write(syntheticFrame(info, 1));
    EXPECT_THROW(writer.write(syntheticFrame(info, 0)), Error) << "timestamps going backwards";
    EXPECT_THROW(RecordingWriter::create(folder, info), Error);
}

} // namespace
} // namespace lightskin::test
