// .oni files damaged in the middle (the reader is OpenNI2's; ours must turn what it
// reports into an Error naming the file, or deliver well-formed frames, never crash or hang).
#include "OniStreams.h"
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/LeakCheck.h>

#include <OpenNI.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <fstream>
#include <iterator>
#include <optional>

namespace lightskin::test {
namespace {

std::string oniBytes() {
    std::ifstream in(dataPath("oni-kinect-v1/3dj_test.oni"), std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(OniCorruptTest, BitFlippedInTheMiddle) {
    const std::string original = oniBytes();
    ASSERT_GT(original.size(), 100000u);
    const auto scratch = scratchDir("oni_bitflip");
    // Three damages: one flipped bit, a flipped 4 KiB block (a bad sector), and zeros over a
    // quarter of the file, each at the middle.
    // An .oni has no checksums: damage inside pixel data cannot be detected and is delivered (all 12
    // frames, well-formed); damage over frame headers must be an error naming the file and the frame.
    struct Damage {
        const char* name;
        std::size_t length;
        char (*apply)(char);
        int expectedFrames;                     ///< delivered before the end or the error
        std::optional<std::int64_t> errorFrame; ///< the frame the error names; nullopt = no error
    };
    const Damage damages[] = {
        {"bit", 1, [](char c) { return char(c ^ 0x10); }, 12, std::nullopt},
        {"block", 4096, [](char c) { return char(~c); }, 12, std::nullopt},
        {"zeros", original.size() / 4, [](char) { return char(0); }, 5, 5},
    };
    for (const Damage& damage : damages) {
        std::string bytes = original;
        for (std::size_t i = 0; i < damage.length; ++i)
            bytes[bytes.size() / 2 + i] = damage.apply(bytes[bytes.size() / 2 + i]);
        const auto path = scratch / (std::string(damage.name) + ".oni");
        std::ofstream(path, std::ios::binary) << bytes;
        int frames = 0;
        try {
            auto source = capture::openFrameSource(path.string());
            RgbdFrame frame;
            while (source->next(frame)) {
                ++frames;
                ASSERT_EQ(frame.depth.type(), CV_16UC1) << damage.name;
                ASSERT_EQ(frame.depth.size(), cv::Size(640, 480)) << damage.name;
                ASSERT_LE(frames, 12) << damage.name << ": more frames than the file holds";
            }
            EXPECT_FALSE(damage.errorFrame.has_value()) << damage.name << ": no error";
        } catch (const Error& error) {
            EXPECT_EQ(error.source(), path.string()) << error.what();
            EXPECT_EQ(error.frame(), damage.errorFrame) << error.what();
            EXPECT_FALSE(error.cause().empty());
        }
        EXPECT_EQ(frames, damage.expectedFrames) << damage.name;
    }
}

/// Copies one stream of 3dj_test.oni (depth + colour, 12 frames) into `out` with OpenNI2's own
/// recorder: playback device, one stream attached, every frame read once. Returns the frames read.
int recordSingleStream(const std::filesystem::path& out, openni::SensorType sensor) {
    EXPECT_EQ(openni::OpenNI::initialize(), openni::STATUS_OK) << openni::OpenNI::getExtendedError();
    sanitizer::keepLoadedModulesMapped(); // as capture does, so LeakSanitizer can scan OpenNI2's drivers
    openni::Device device;
    const std::string input = dataPath("oni-kinect-v1/3dj_test.oni").string();
    EXPECT_EQ(device.open(input.c_str()), openni::STATUS_OK) << openni::OpenNI::getExtendedError();
    device.getPlaybackControl()->setSpeed(-1.0f); // manual stepping: every frame, in order
    device.getPlaybackControl()->setRepeatEnabled(false);
    openni::VideoStream stream;
    EXPECT_EQ(stream.create(device, sensor), openni::STATUS_OK) << openni::OpenNI::getExtendedError();
    const int frames = device.getPlaybackControl()->getNumberOfFrames(stream);
    openni::Recorder recorder;
    EXPECT_EQ(recorder.create(out.c_str()), openni::STATUS_OK) << openni::OpenNI::getExtendedError();
    EXPECT_EQ(recorder.attach(stream), openni::STATUS_OK) << openni::OpenNI::getExtendedError();
    EXPECT_EQ(stream.start(), openni::STATUS_OK);
    EXPECT_EQ(recorder.start(), openni::STATUS_OK);
    openni::VideoFrameRef frame;
    int read = 0;
    for (int i = 0; i < frames && stream.readFrame(&frame) == openni::STATUS_OK; ++i) ++read;
    recorder.stop();
    recorder.destroy();
    frame.release();
    stopAndDestroy({&stream});
    device.close();
    // Every initialize needs its shutdown: without it OpenNI2 never unloads its drivers, and the
    // PS1080 / PSLink drivers' per-process objects stay allocated (LeakSanitizer: 240 bytes in 10
    // blocks at exit, the first ASan run's finding).
    openni::OpenNI::shutdown();
    return read;
}

// An .oni with one stream, made by OpenNI2's recorder from the two-stream sample.
// Depth only: frames without colour (our source's documented behaviour for a depth-only device).
// Colour only: no VALs without depth, so opening it is an error naming the file and the cause.
TEST(OniCorruptTest, SingleStreamFiles) {
    const auto scratch = scratchDir("oni_single_stream");
    const auto depthOnly = scratch / "depth_only.oni", colourOnly = scratch / "colour_only.oni";
    ASSERT_GT(recordSingleStream(depthOnly, openni::SENSOR_DEPTH), 0);
    ASSERT_GT(recordSingleStream(colourOnly, openni::SENSOR_COLOR), 0);

    auto source = capture::openFrameSource(depthOnly.string());
    RgbdFrame frame;
    int frames = 0;
    while (source->next(frame)) {
        ++frames;
        ASSERT_EQ(frame.depth.type(), CV_16UC1);
        ASSERT_EQ(frame.depth.size(), cv::Size(640, 480));
        EXPECT_FALSE(frame.hasColour()) << "frame " << frames;
        EXPECT_GT(cv::countNonZero(frame.depth), 0) << "frame " << frames << ": no depth measured";
    }
    EXPECT_GE(frames, 1);

    try {
        capture::openFrameSource(colourOnly.string());
        ADD_FAILURE() << "a colour-only .oni opened";
    } catch (const Error& error) {
        EXPECT_EQ(error.source(), colourOnly.string()) << error.what();
        EXPECT_NE(error.cause().find("no depth stream"), std::string::npos) << error.what();
    }
}

} // namespace
} // namespace lightskin::test
