// Disk full: the recorder's writes hit a file-size limit (RLIMIT_FSIZE, the
// per-process stand-in for a full disk that needs no mount: write(2) fails with EFBIG instead of
// ENOSPC, through the same error paths). Every frame is written or counted as dropped, the first
// error names the file and the cause, and every frame completed before the limit reads back exactly.
#include "CaptureTestUtil.h"
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/capture/Recorder.h>
#include <lightskin/capture/Recording.h>

#include <gtest/gtest.h>

#include <csignal>
#include <sys/resource.h>

namespace lightskin::test {
namespace {

/// Lowers the soft file-size limit for this process (each test is its own process under CTest) and
/// ignores SIGXFSZ, whose default action would kill the process at the first write past the limit.
class FileSizeLimit {
public:
    explicit FileSizeLimit(rlim_t bytes) {
        EXPECT_EQ(::getrlimit(RLIMIT_FSIZE, &saved_), 0);
        rlimit lowered = saved_;
        lowered.rlim_cur = bytes;
        EXPECT_EQ(::setrlimit(RLIMIT_FSIZE, &lowered), 0);
        previousHandler_ = std::signal(SIGXFSZ, SIG_IGN);
    }
    ~FileSizeLimit() {
        ::setrlimit(RLIMIT_FSIZE, &saved_);
        std::signal(SIGXFSZ, previousHandler_);
    }
    FileSizeLimit(const FileSizeLimit&) = delete;
    FileSizeLimit& operator=(const FileSizeLimit&) = delete;

private:
    rlimit saved_{};
    void (*previousHandler_)(int) = SIG_DFL;
};

TEST(RecorderDiskFullTest, StopsCleanlyAndEveryCompletedFrameIsReadable) {
    const auto folder = scratchDir("recorder_disk_full") / "rec";
    // 32x24 random (incompressible) frames: colour PNG ~2.4 KB, depth PNG ~1.6 KB, index line ~125
    // bytes. With a 4 KiB limit every image fits and the index fills after ~32 frames, so the limit
    // is hit in the middle of the 60 frames by the file that grows (on a full disk the next write
    // of any file would fail, through the same error path).
    const auto info = smallRecordingInfo(32, 24);
    constexpr std::uint32_t kFrames = 60;
    capture::RecorderStats stats;
    {
        const FileSizeLimit limit(4096);
        auto recorder =
            capture::Recorder::start(capture::RecordingWriter::create(folder, info), capture::RecorderOptions{64});
        for (std::uint32_t i = 0; i < kFrames; ++i) ASSERT_TRUE(recorder->push(syntheticFrame(info, i)));
        stats = recorder->finish();
    }
    EXPECT_EQ(stats.pushed, kFrames);
    EXPECT_EQ(stats.written + stats.dropped, kFrames);
    EXPECT_GT(stats.written, 0); // the limit was not hit at once ...
    EXPECT_GT(stats.dropped, 0); // ... but it was hit
    EXPECT_NE(stats.firstError.find(capture::kRecordingIndexFile), std::string::npos) << stats.firstError;
    // A write cut short at the limit is reported as "No space left on device" (what a short write
    // means on a full disk); a write refused outright would give "File too large". Either way:
    EXPECT_NE(stats.firstError.find("cannot append to the index"), std::string::npos) << stats.firstError;

    // The recording reads back: exactly the written frames, bit for bit. Whether the end marker
    // fitted into what was left is not asserted (here it does: the partial line is truncated away);
    // when it is there, the reader checks that it counts exactly the frames before it.
    const auto summary = capture::readRecordingSummary(folder);
    EXPECT_EQ(summary.frameCount, stats.written);
    auto source = capture::openFrameSource(folder.string());
    RgbdFrame frame;
    std::int64_t read = 0;
    while (source->next(frame)) {
        const RgbdFrame expected = syntheticFrame(info, std::uint32_t(read));
        ASSERT_TRUE(identical(frame.depth, expected.depth)) << "frame " << read;
        ASSERT_TRUE(identical(frame.colour, expected.colour)) << "frame " << read;
        ++read;
    }
    EXPECT_EQ(read, stats.written);
}

} // namespace
} // namespace lightskin::test
