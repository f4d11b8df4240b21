// The live freenect:// code path replayed by Debian's fakenect: a recording is written as a
// fakenect dump, and this binary runs with LD_LIBRARY_PATH pointing at fakenect's libfreenect
// (set by CTest, see CMakeLists.txt), so FrameSource's libfreenect backend reads the dump as if
// a Kinect were plugged in.
#include "CaptureTestUtil.h"
#include "TestPaths.h"

#include <lightskin/capture/Fakenect.h>
#include <lightskin/capture/FrameSource.h>
#include <lightskin/capture/Recording.h>
#include <lightskin/core/Error.h>

#include <gtest/gtest.h>
#include <libfreenect.h>

#include <cmath>
#include <cstdlib>
#include <dlfcn.h>

namespace lightskin::test {
namespace {

bool fakenectLoaded() {
    Dl_info info{};
    return dladdr(reinterpret_cast<void*>(&freenect_init), &info) != 0 && info.dli_fname &&
           std::string(info.dli_fname).find("fakenect") != std::string::npos;
}

TEST(FakenectTest, LiveCodePathReplaysARecording) {
    if (!fakenectLoaded())
        GTEST_SKIP() << "run through CTest (LD_LIBRARY_PATH=/usr/lib/x86_64-linux-gnu/fakenect), not directly";
    const auto scratch = scratchDir("fakenect_live");
    auto info = smallRecordingInfo(640, 480);
    std::vector<RgbdFrame> frames;
    {
        auto writer = capture::RecordingWriter::create(scratch / "rec", info);
        for (std::uint32_t i = 0; i < 4; ++i) {
            RgbdFrame frame = syntheticFrame(info, i);
            cv::RNG(i).fill(frame.depth, cv::RNG::UNIFORM, 500, 8001); // Kinect range in millimetres
            frame.depth(cv::Rect(0, 0, 64, 48)).setTo(0);              // a hole
            frame.depth.at<std::uint16_t>(100, 100) = 250;             // closer than a Kinect sees
            writer.write(frame);
            frames.push_back(frame.clone());
        }
    }
    auto recording = capture::openFrameSource((scratch / "rec").string());
    EXPECT_EQ(capture::writeFakenectDump(*recording, scratch / "dump"), 4);

    ASSERT_EQ(setenv("FAKENECT_PATH", (scratch / "dump").c_str(), 1), 0);
    capture::FrameSourceOptions raw;
    raw.softwareRegistration = false; // compares the delivered pixels with the written ones
    auto live = capture::openFrameSource("freenect://0", raw);
    EXPECT_EQ(live->info().kind, "freenect");
    EXPECT_TRUE(live->info().live);
    // Debian's fakenect offers only raw 11-bit disparity: the source converts it (unregistered),
    // with the Kinect v1 default extrinsic for software registration (here switched off).
    EXPECT_EQ(live->info().registration, DepthRegistration::Unregistered);
    EXPECT_NEAR(live->info().colour_T_depth.translation().x, 0.025, 0.001);
    EXPECT_FALSE(live->info().softwareRegistration.has_value());
    EXPECT_FALSE(live->frameCount().has_value());
    RgbdFrame frame;
    std::size_t received = 0;
    while (received < frames.size() && live->next(frame)) {
        EXPECT_EQ(frame.index, std::int64_t(received));
        // Depth went through the Kinect's disparity quantisation: within half a disparity step
        // (0.5 * 0.0030711 * z^2 m) plus 0.5 mm rounding of each direction.
        const cv::Mat& expected = frames[received].depth;
        int worse = 0, holes = 0;
        for (int v = 0; v < 480; ++v)
            for (int u = 0; u < 640; ++u) {
                const double z = expected.at<std::uint16_t>(v, u) * 0.001;
                const double got = frame.depth.at<std::uint16_t>(v, u) * 0.001;
                if (z < 0.3) {
                    holes += got == 0.0 ? 1 : 0;
                    continue;
                }
                if (std::abs(got - z) > 0.5 * 0.0030711016 * z * z * 1.01 + 0.001) ++worse;
            }
        EXPECT_EQ(worse, 0) << "depth of frame " << received;
        EXPECT_EQ(holes, 64 * 48 + 1) << "missing and too-close depth stays missing";
        EXPECT_TRUE(identical(frame.colour, frames[received].colour)) << "colour of frame " << received;
        EXPECT_NO_THROW(frame.validate("freenect"));
        ++received;
    }
    EXPECT_EQ(received, frames.size());
    EXPECT_FALSE(live->next(frame)) << "fakenect ends the stream after the last index line";
    EXPECT_EQ(live->framesDropped(), 0);
}

TEST(FakenectTest, DumpWriterRefusesWhatFakenectCannotReplay) {
    const auto scratch = scratchDir("fakenect_refuse");
    const auto info = smallRecordingInfo(32, 24);
    {
        auto writer = capture::RecordingWriter::create(scratch / "rec", info);
        writer.write(syntheticFrame(info, 0));
    }
    auto recording = capture::openFrameSource((scratch / "rec").string());
    EXPECT_THROW(capture::writeFakenectDump(*recording, scratch / "dump"), Error); // not 640x480
}

} // namespace
} // namespace lightskin::test
