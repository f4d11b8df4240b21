// Issue 21 part 5, .oni files damaged in the middle (the reader is OpenNI2's; ours must turn what it
// reports into an Error naming the file, or deliver well-formed frames, never crash or hang).
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>

#include <gtest/gtest.h>

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

} // namespace
} // namespace lightskin::test
