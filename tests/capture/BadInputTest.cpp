// Bad input: every case throws lightskin::Error naming the file, the frame (where there is one)
// and the cause; nothing crashes, hangs or allocates what a file claims before checking it.
#include "CaptureTestUtil.h"
#include "ExpectError.h"
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/capture/Recording.h>
#include <lightskin/core/Error.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <fstream>

namespace lightskin::test {
namespace {



void truncateFile(const std::filesystem::path& path, std::uintmax_t keep) { std::filesystem::resize_file(path, keep); }

std::string readText(const std::filesystem::path& path) {
    std::ifstream in(path);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void replaceInFile(const std::filesystem::path& path, const std::string& from, const std::string& to) {
    std::string text = readText(path);
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    std::ofstream(path, std::ios::trunc) << text;
}

TEST(BadInputTest, TruncatedPng) {
    const auto folder = makeRecording("bad_truncated_png");
    truncateFile(folder / "depth/000001.png", std::filesystem::file_size(folder / "depth/000001.png") / 2);
    expectError([&] { readAll(folder); }, {"depth/000001.png", 1, "cannot decode"});
    truncateFile(folder / "colour/000002.png", 20); // inside the IHDR chunk
    auto source = capture::openFrameSource(folder.string());
    source->seek(2);
    RgbdFrame frame;
    expectError([&] { source->next(frame); }, {"colour/000002.png", 2, "truncated PNG"});
}

TEST(BadInputTest, CorruptPng) {
    const auto folder = makeRecording("bad_corrupt_png");
    const auto path = folder / "depth/000000.png";
    std::string bytes = readText(path);
    for (std::size_t i = 60; i < bytes.size() - 20; i += 7) bytes[i] = char(bytes[i] ^ 0x5a); // damage the pixel data
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
    expectError([&] { readAll(folder); }, {"depth/000000.png", 0, "cannot decode"});
    std::ofstream(path, std::ios::binary | std::ios::trunc) << "this is not an image";
    expectError([&] { readAll(folder); }, {"depth/000000.png", 0, "not a PNG, TIFF or JPEG file"});
}

TEST(BadInputTest, MissingFrameFile) {
    const auto folder = makeRecording("bad_missing_file");
    std::filesystem::remove(folder / "colour/000001.png");
    expectError([&] { readAll(folder); }, {"colour/000001.png", 1, "missing"});
}

TEST(BadInputTest, MismatchedSizes) {
    const auto folder = makeRecording("bad_sizes");
    cv::imwrite((folder / "depth/000002.png").string(), cv::Mat(12, 16, CV_16UC1, cv::Scalar(1)));
    expectError([&] { readAll(folder); }, {"depth/000002.png", 2, "expected 32x24"});

    // A TUM folder whose colour and depth images differ in size (registered: must match).
    const auto tum = scratchDir("bad_sizes_tum");
    cv::imwrite((tum / "c.png").string(), cv::Mat(480, 640, CV_8UC3, cv::Scalar(1, 2, 3)));
    cv::imwrite((tum / "d.png").string(), cv::Mat(240, 320, CV_16UC1, cv::Scalar(1)));
    std::ofstream(tum / "rgb.txt") << "1.0 c.png\n";
    std::ofstream(tum / "depth.txt") << "1.0 d.png\n";
    expectError([&] { readAll(tum); }, {"d.png", 0, "expected 640x480"});
}

TEST(BadInputTest, EightBitOrFloatDepth) {
    const auto folder = makeRecording("bad_depth_type");
    cv::imwrite((folder / "depth/000000.png").string(), cv::Mat(24, 32, CV_8UC1, cv::Scalar(7)));
    expectError([&] { readAll(folder); }, {"depth/000000.png", 0, "16-bit single-channel"});

    // Float depth in a TIFF (what some tools write) where 16-bit is expected.
    const auto tum = scratchDir("bad_depth_float");
    cv::imwrite((tum / "c.png").string(), cv::Mat(24, 32, CV_8UC3, cv::Scalar(1, 2, 3)));
    cv::imwrite((tum / "d.tiff").string(), cv::Mat(24, 32, CV_32FC1, cv::Scalar(1.5)));
    std::ofstream(tum / "rgb.txt") << "1.0 c.png\n";
    std::ofstream(tum / "depth.txt") << "1.0 d.tiff\n";
    capture::FrameSourceOptions options;
    options.intrinsics = CameraIntrinsics{32, 24, 30, 30, 15.5, 11.5, {}};
    auto source = capture::openFrameSource(tum.string(), options);
    RgbdFrame frame;
    expectError([&] { source->next(frame); }, {"d.tiff", 0, "32-bit float"});
}

TEST(BadInputTest, TruncatedAndCorruptTiff) {
    const auto tum = scratchDir("bad_tiff");
    cv::imwrite((tum / "c.png").string(), cv::Mat(480, 640, CV_8UC3, cv::Scalar(1, 2, 3)));
    cv::Mat depth(480, 640, CV_16UC1);
    cv::RNG(5).fill(depth, cv::RNG::UNIFORM, 0, 4000);
    cv::imwrite((tum / "d.tiff").string(), depth);
    std::ofstream(tum / "rgb.txt") << "1.0 c.png\n2.0 c.png\n";
    std::ofstream(tum / "depth.txt") << "1.0 d.tiff\n2.0 e.tiff\n";
    std::filesystem::copy_file(tum / "d.tiff", tum / "e.tiff");
    truncateFile(tum / "d.tiff", 4000);
    expectError([&] { readAll(tum); }, {"d.tiff", 0, "TIFF"});
    // A TIFF directory claiming a 1,000,000-pixel-wide image is refused before decoding.
    std::string bytes = readText(tum / "e.tiff");
    ASSERT_EQ(bytes.substr(0, 2), "II");
    const std::uint32_t ifd = std::uint32_t(std::uint8_t(bytes[4])) | std::uint32_t(std::uint8_t(bytes[5])) << 8 |
                              std::uint32_t(std::uint8_t(bytes[6])) << 16 | std::uint32_t(std::uint8_t(bytes[7])) << 24;
    const int entries = std::uint8_t(bytes[ifd]) | std::uint8_t(bytes[ifd + 1]) << 8;
    for (int i = 0; i < entries; ++i) {
        char* entry = &bytes[ifd + 2 + std::uint32_t(i) * 12];
        if ((std::uint8_t(entry[0]) | std::uint8_t(entry[1]) << 8) == 256) { // ImageWidth
            entry[2] = 4;                                                    // LONG
            entry[3] = 0;
            const std::uint32_t huge = 1000000;
            std::memcpy(entry + 8, &huge, 4);
        }
    }
    std::ofstream(tum / "e.tiff", std::ios::binary | std::ios::trunc) << bytes;
    auto source = capture::openFrameSource(tum.string());
    source->seek(1);
    RgbdFrame frame;
    expectError([&] { source->next(frame); }, {"e.tiff", 1, "absurd size"});
}

TEST(BadInputTest, AbsurdSizes) {
    // PNG header claiming 100000 x 100000 pixels: refused from the header, nothing allocated.
    const auto folder = makeRecording("bad_absurd_png");
    std::string bytes = readText(folder / "depth/000000.png");
    const unsigned char huge[8] = {0, 1, 0x86, 0xa0, 0, 1, 0x86, 0xa0};
    std::memcpy(&bytes[16], huge, 8);
    std::ofstream(folder / "depth/000000.png", std::ios::binary | std::ios::trunc) << bytes;
    expectError([&] { readAll(folder); }, {"depth/000000.png", 0, "absurd size"});

    // The same for a JPEG frame header (65535 x 65535).
    const auto jpegFolder = scratchDir("bad_absurd_jpeg") / "rec";
    auto jpegInfo = smallRecordingInfo();
    jpegInfo.jpegColour = true;
    {
        auto writer = capture::RecordingWriter::create(jpegFolder, jpegInfo);
        writer.write(syntheticFrame(jpegInfo, 0));
    }
    std::string jpeg = readText(jpegFolder / "colour/000000.jpg");
    const auto sof = jpeg.find("\xff\xc0");
    ASSERT_NE(sof, std::string::npos);
    for (std::size_t i = 5; i < 9; ++i) jpeg[sof + i] = char(0xff);
    std::ofstream(jpegFolder / "colour/000000.jpg", std::ios::binary | std::ios::trunc) << jpeg;
    expectError([&] { readAll(jpegFolder); }, {"colour/000000.jpg", 0, "absurd size"});

    const auto header = makeRecording("bad_absurd_header");
    replaceInFile(header / capture::kRecordingHeaderFile, "\"width\": 32", "\"width\": 1000000000");
    expectError([&] { capture::openFrameSource(header.string()); },
                {capture::kRecordingHeaderFile, std::nullopt, "absurd image size"});
}

TEST(BadInputTest, EmptyFolderAndUnknownSources) {
    const auto empty = scratchDir("bad_empty");
    expectError([&] { capture::openFrameSource(empty.string()); }, {"bad_empty", std::nullopt, "neither"});
    expectError([&] { capture::openFrameSource((empty / "nothing").string()); },
                {"nothing", std::nullopt, "no such file"});
    std::ofstream(empty / "clip.mp4") << "x";
    expectError([&] { capture::openFrameSource((empty / "clip.mp4").string()); },
                {"clip.mp4", std::nullopt, "unknown source"});
    expectError([&] { capture::openFrameSource("freenect://abc"); }, {"freenect://abc", std::nullopt, "device index"});
    // An empty rgb.txt/depth.txt pair: nothing to associate.
    std::ofstream(empty / "rgb.txt") << "# nothing\n";
    std::ofstream(empty / "depth.txt") << "# nothing\n";
    expectError([&] { capture::openFrameSource(empty.string()); }, {"bad_empty", std::nullopt, "no colour and depth"});
}

TEST(BadInputTest, MalformedManifest) {
    const auto folder = makeRecording("bad_manifest");
    std::ofstream(folder / capture::kRecordingHeaderFile, std::ios::trunc)
        << "{\"format\": \"lightskin-recording\", \"vers";
    expectError([&] { capture::openFrameSource(folder.string()); },
                {capture::kRecordingHeaderFile, std::nullopt, "malformed JSON"});

    const auto newer = makeRecording("bad_manifest_version");
    replaceInFile(newer / capture::kRecordingHeaderFile, "\"version\": 1", "\"version\": 99");
    expectError([&] { capture::openFrameSource(newer.string()); },
                {capture::kRecordingHeaderFile, std::nullopt, "not supported"});

    const auto index = makeRecording("bad_manifest_index");
    replaceInFile(index / capture::kRecordingIndexFile, "{\"colour\":\"colour/000001.png\"", "{\"colour\":[1,2]");
    expectError([&] { capture::openFrameSource(index.string()); },
                {capture::kRecordingIndexFile, 1, "malformed index line"});

    const auto garbage = makeRecording("bad_manifest_garbage");
    replaceInFile(garbage / capture::kRecordingIndexFile, "{\"colour\":\"colour/000001.png\"",
                  "#!garbage {\"colour\":\"colour/000001.png\"");
    expectError([&] { capture::openFrameSource(garbage.string()); },
                {capture::kRecordingIndexFile, 1, "malformed index line"});

    // TUM lists with a malformed line.
    const auto tum = scratchDir("bad_manifest_tum");
    std::ofstream(tum / "rgb.txt") << "# header\n1.0 c.png\nabc c.png\n";
    std::ofstream(tum / "depth.txt") << "1.0 d.png\n";
    expectError([&] { capture::openFrameSource(tum.string()); },
                {"rgb.txt", std::nullopt, "line 3: 'abc' is not a number"});
    std::ofstream(tum / "rgb.txt", std::ios::trunc) << "1.0 c.png extra\n";
    expectError([&] { capture::openFrameSource(tum.string()); },
                {"rgb.txt", std::nullopt, "line 1: expected 'timestamp file'"});
    std::ofstream(tum / "rgb.txt", std::ios::trunc) << "1.0 c.png\n";
    std::ofstream(tum / "groundtruth.txt") << "1.0 0 0 0 0 0 0\n";
    expectError([&] { capture::openFrameSource(tum.string()); }, {"groundtruth.txt", std::nullopt, "line 1"});
}

TEST(BadInputTest, TimestampsGoingBackwards) {
    const auto tum = scratchDir("bad_time_tum");
    std::ofstream(tum / "rgb.txt") << "2.0 a.png\n1.0 b.png\n";
    std::ofstream(tum / "depth.txt") << "1.0 d.png\n";
    expectError([&] { capture::openFrameSource(tum.string()); },
                {"rgb.txt", std::nullopt, "line 2: timestamps go backwards"});

    const auto folder = makeRecording("bad_time_recording");
    std::string index = readText(folder / capture::kRecordingIndexFile);
    const auto first = index.find("\"depthTime\":");
    index.replace(index.find("\"depthTime\":", first + 1), 12, "\"depthTime\":-5.0,\"x\":");
    std::ofstream(folder / capture::kRecordingIndexFile, std::ios::trunc) << index;
    expectError([&] { capture::openFrameSource(folder.string()); },
                {capture::kRecordingIndexFile, 1, "timestamps go backwards"});
}

TEST(BadInputTest, PathsLeavingTheFolderAreRefused) {
    const auto folder = makeRecording("bad_paths");
    std::ofstream(folder.parent_path() / "outside.png") << "x";
    const std::string original = readText(folder / capture::kRecordingIndexFile);
    replaceInFile(folder / capture::kRecordingIndexFile, "\"depth/000001.png\"", "\"../outside.png\"");
    expectError([&] { capture::openFrameSource(folder.string()); },
                {capture::kRecordingIndexFile, 1, "leaves the folder"});
    std::ofstream(folder / capture::kRecordingIndexFile, std::ios::trunc) << original;
    replaceInFile(folder / capture::kRecordingIndexFile, "\"depth/000001.png\"", "\"/etc/hostname\"");
    expectError([&] { capture::openFrameSource(folder.string()); }, {capture::kRecordingIndexFile, 1, "absolute"});
    // A symbolic link inside the folder pointing outside it.
    std::ofstream(folder / capture::kRecordingIndexFile, std::ios::trunc) << original;
    std::filesystem::create_directory_symlink(folder.parent_path(), folder / "link");
    replaceInFile(folder / capture::kRecordingIndexFile, "\"depth/000001.png\"", "\"link/outside.png\"");
    expectError([&] { capture::openFrameSource(folder.string()); },
                {capture::kRecordingIndexFile, 1, "outside the folder"});

    const auto tum = scratchDir("bad_paths_tum");
    std::ofstream(tum / "rgb.txt") << "1.0 ../../secret.png\n";
    std::ofstream(tum / "depth.txt") << "1.0 d.png\n";
    expectError([&] { capture::openFrameSource(tum.string()); }, {"rgb.txt", std::nullopt, "leaves the folder"});
}

} // namespace
} // namespace lightskin::test
