// A camera that stops delivering in the middle of `live` (mr::LiveFrameReader,
// which LiveCommand reads its source through). A fake live source follows a script of frames and
// stalls (what OpenNI2Source and FreenectSource throw after their live timeout): the stall is shown
// with its cause, the run goes on, the recovery is shown when frames come back and then cleared;
// a stall beyond the give-up time and any other error end the run with the cause.
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/mr/LiveFrameReader.h>

#include <gtest/gtest.h>

#include <string>

namespace lightskin::test {
namespace {

constexpr const char* kStallCause = "no frame for 3000 ms: device stalled or unplugged";

/// 'F' a frame, 'S' a stall, 'X' a fatal error; past the script's end the source ends.
class ScriptedLiveSource : public capture::FrameSource {
public:
    explicit ScriptedLiveSource(std::string script)
        : FrameSource(liveInfo(), {})
        , script_(std::move(script)) {}

protected:
    bool readNext(RgbdFrame& out) override {
        if (at_ >= script_.size()) return false;
        const char event = script_[at_++];
        if (event == 'S') throw capture::SourceStalled("fake://camera", index_, kStallCause);
        if (event == 'X') throw Error("fake://camera", index_, "USB transfer failed");
        out.depth.create(4, 4, CV_16UC1);
        out.depth.setTo(1000);
        out.colour.create(4, 4, CV_8UC3);
        stampFrame(out, index_++);
        return true;
    }

private:
    static capture::FrameSourceInfo liveInfo() {
        capture::FrameSourceInfo info;
        info.kind = "fake";
        info.uri = "fake://camera";
        info.live = true;
        info.colourIntrinsics = info.depthIntrinsics = CameraIntrinsics{4, 4, 4.0, 4.0, 1.5, 1.5, {}};
        return info;
    }
    std::string script_;
    std::size_t at_ = 0;
    std::int64_t index_ = 0;
};

using Result = mr::LiveFrameReader::Result;

TEST(LiveFrameReaderTest, StallIsShownAndRecoveredWhenFramesComeBack) {
    ScriptedLiveSource source("FFSSSFFFFF");
    mr::LiveFrameReaderOptions options;
    options.recoveredFrames = 3;
    mr::LiveFrameReader reader(source, options);
    RgbdFrame frame;
    ASSERT_EQ(reader.next(frame), Result::Frame);
    ASSERT_EQ(reader.next(frame), Result::Frame);
    EXPECT_EQ(reader.status(), "");
    for (int i = 0; i < 3; ++i) {
        ASSERT_EQ(reader.next(frame), Result::Stalled) << "stall call " << i;
        EXPECT_TRUE(reader.stalled());
        EXPECT_EQ(frame.index, 1) << "a stall leaves the last frame in place";
        EXPECT_NE(reader.status().find("camera: no frame for"), std::string::npos) << reader.status();
        EXPECT_NE(reader.status().find(kStallCause), std::string::npos) << reader.status();
    }
    EXPECT_EQ(reader.stalls(), 1) << "one stall, however many timeouts it lasted";
    ASSERT_EQ(reader.next(frame), Result::Frame);
    EXPECT_FALSE(reader.stalled());
    EXPECT_EQ(frame.index, 2);
    EXPECT_NE(reader.status().find("camera: frames again after a"), std::string::npos) << reader.status();
    // Shown for recoveredFrames frames after the first one back, then cleared.
    for (int i = 0; i < 3; ++i) {
        ASSERT_EQ(reader.next(frame), Result::Frame);
        EXPECT_EQ(reader.status().empty(), i == 2) << "frame " << i << ": '" << reader.status() << "'";
    }
    ASSERT_EQ(reader.next(frame), Result::Frame);
    ASSERT_EQ(reader.next(frame), Result::Ended);
}

TEST(LiveFrameReaderTest, StallBeyondTheGiveUpTimeAndOtherErrorsEndTheRun) {
    {
        ScriptedLiveSource source("FS");
        mr::LiveFrameReaderOptions options;
        options.giveUpSeconds = 0.0; // the first stall is already too long
        mr::LiveFrameReader reader(source, options);
        RgbdFrame frame;
        ASSERT_EQ(reader.next(frame), Result::Frame);
        try {
            reader.next(frame);
            ADD_FAILURE() << "a stall beyond the give-up time was survived";
        } catch (const Error& error) {
            EXPECT_EQ(error.source(), "fake://camera");
            EXPECT_EQ(error.frame(), std::optional<std::int64_t>(1));
            EXPECT_NE(error.cause().find(kStallCause), std::string::npos) << error.what();
            EXPECT_NE(error.cause().find("gave up after"), std::string::npos) << error.what();
        }
    }
    ScriptedLiveSource source("FX");
    mr::LiveFrameReader reader(source);
    RgbdFrame frame;
    ASSERT_EQ(reader.next(frame), Result::Frame);
    try {
        reader.next(frame);
        ADD_FAILURE() << "a fatal source error was taken for a stall";
    } catch (const capture::SourceStalled&) {
        ADD_FAILURE() << "a fatal source error was taken for a stall";
    } catch (const Error& error) {
        EXPECT_EQ(error.cause(), "USB transfer failed");
    }
}

} // namespace
} // namespace lightskin::test
