// Bad input: each case names the file (or source), the frame where there is one,
// and the cause; none crashes or is silently accepted. Complements BadInputTest.cpp.
#include "CaptureTestUtil.h"
#include "ExpectError.h"
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/capture/Recording.h>
#include <lightskin/core/Error.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <fstream>
#include <sstream>
#include <vector>

namespace lightskin::test {
namespace {

using nlohmann::json;



std::vector<std::string> readLines(const std::filesystem::path& path) {
    std::ifstream in(path);
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    return lines;
}

void writeLines(const std::filesystem::path& path, const std::vector<std::string>& lines) {
    std::ofstream out(path, std::ios::trunc);
    for (const auto& line : lines) out << line << "\n";
}

/// Rewrites index line `i` (0 = frame 0) through `edit`.
template <typename Edit>
void editIndexLine(const std::filesystem::path& folder, std::size_t i, Edit&& edit) {
    auto lines = readLines(folder / capture::kRecordingIndexFile);
    json line = json::parse(lines.at(i));
    edit(line);
    lines[i] = line.dump();
    writeLines(folder / capture::kRecordingIndexFile, lines);
}

template <typename Edit>
void editHeader(const std::filesystem::path& folder, Edit&& edit) {
    std::ifstream in(folder / capture::kRecordingHeaderFile);
    json header = json::parse(in);
    in.close();
    edit(header);
    std::ofstream(folder / capture::kRecordingHeaderFile, std::ios::trunc) << header.dump(2);
}

/// A TUM folder with two 32x24 frames and a valid sidecar; tests overwrite one file.
std::filesystem::path makeTum(const std::string& name) {
    const auto folder = scratchDir(name);
    cv::imwrite((folder / "c.png").string(), cv::Mat(24, 32, CV_8UC3, cv::Scalar(1, 2, 3)));
    cv::imwrite((folder / "d.png").string(), cv::Mat(24, 32, CV_16UC1, cv::Scalar(5000)));
    std::ofstream(folder / "rgb.txt") << "1.0 c.png\n2.0 c.png\n";
    std::ofstream(folder / "depth.txt") << "1.0 d.png\n2.0 d.png\n";
    std::ofstream(folder / "lightskin-camera.json")
        << R"({"colour":{"width":32,"height":24,"fx":30,"fy":30,"cx":15.5,"cy":11.5},"depthScaleMetres":0.0002})";
    return folder;
}

constexpr const char* kIndex = capture::kRecordingIndexFile;
constexpr const char* kHeader = capture::kRecordingHeaderFile;

TEST(MalformedInputTest, FrameNumbersOutOfOrderDuplicatedOrMissing) {
    // Missing: frame 1 is absent, the second line says 2.
    const auto missing = makeRecording("bad_frame_missing");
    editIndexLine(missing, 1, [](json& line) { line["frame"] = 2; });
    expectError([&] { capture::openFrameSource(missing.string()); },
                {kIndex, 1, "frame number 2 where 1 was expected"});
    // Duplicated: frame 0 twice.
    const auto duplicate = makeRecording("bad_frame_duplicate");
    editIndexLine(duplicate, 1, [](json& line) { line["frame"] = 0; });
    expectError([&] { capture::openFrameSource(duplicate.string()); },
                {kIndex, 1, "frame number 0 where 1 was expected"});
    // Out of order: lines 1 and 2 swapped.
    const auto swapped = makeRecording("bad_frame_swapped");
    auto lines = readLines(swapped / kIndex);
    std::swap(lines.at(1), lines.at(2));
    writeLines(swapped / kIndex, lines);
    expectError([&] { capture::openFrameSource(swapped.string()); },
                {kIndex, 1, "frame number 2 where 1 was expected"});
    // Not a whole number.
    const auto fraction = makeRecording("bad_frame_fraction");
    editIndexLine(fraction, 1, [](json& line) { line["frame"] = 1.5; });
    expectError([&] { capture::openFrameSource(fraction.string()); },
                {kIndex, 1, "frame number 1.5 where 1 was expected"});
}

TEST(MalformedInputTest, NonFiniteTimestamps) {
    // JSON has no NaN or infinity; the nearest a file can get is a number that overflows, which
    // the parser refuses by name.
    const auto folder = makeRecording("bad_time_infinite");
    auto lines = readLines(folder / kIndex);
    const auto at = lines.at(2).find("\"depthTime\":");
    ASSERT_NE(at, std::string::npos);
    lines[2].insert(at, "\"depthTime\":1e999,\"x\":");
    writeLines(folder / kIndex, lines);
    expectError([&] { capture::openFrameSource(folder.string()); }, {kIndex, 2, "number overflow parsing '1e999'"});

    for (const char* bad : {"nan", "inf", "-inf"}) {
        const auto tum = makeTum(std::string("bad_time_tum_") + (bad[0] == '-' ? "minf" : bad));
        std::ofstream(tum / "depth.txt", std::ios::trunc) << "1.0 d.png\n" << bad << " d.png\n";
        expectError([&] { capture::openFrameSource(tum.string()); },
                    {"depth.txt", std::nullopt, std::string("line 2: '") + bad + "' is not a number"});
    }
}

TEST(MalformedInputTest, ZeroOrNonFiniteFocalLength) {
    const auto zero = makeRecording("bad_focal_zero");
    editHeader(zero, [](json& header) { header["colour"]["fx"] = 0.0; });
    expectError([&] { capture::openFrameSource(zero.string()); }, {kHeader, std::nullopt, "zero focal length"});

    const auto infinite = makeRecording("bad_focal_infinite");
    editHeader(infinite, [](json& header) { header["depth"]["fy"] = "FY"; });
    std::string text = readText(infinite / kHeader);
    text.replace(text.find("\"FY\""), 4, "1e999");
    std::ofstream(infinite / kHeader, std::ios::trunc) << text;
    expectError([&] { capture::openFrameSource(infinite.string()); },
                {kHeader, std::nullopt, "number overflow parsing '1e999'"});

    const auto tum = makeTum("bad_focal_tum");
    std::ofstream(tum / "lightskin-camera.json", std::ios::trunc)
        << R"({"colour":{"width":32,"height":24,"fx":0,"fy":30,"cx":15.5,"cy":11.5}})";
    expectError([&] { capture::openFrameSource(tum.string()); },
                {"lightskin-camera.json", std::nullopt, "zero focal length"});
}

TEST(MalformedInputTest, NonUnitQuaternion) {
    const auto index = makeRecording("bad_quaternion_index");
    editIndexLine(index, 2, [](json& line) {
        line["world_T_camera"] = {{"rotationXYZW", {0, 0, 0, 2}}, {"translation", {0, 0, 0}}};
    });
    expectError([&] { capture::openFrameSource(index.string()); }, {kIndex, 2, "not unit length"});

    const auto header = makeRecording("bad_quaternion_header");
    editHeader(header, [](json& h) {
        h["colour_T_depth"] = {{"rotationXYZW", {0.1, 0, 0, 0.9}}, {"translation", {0.025, 0, 0}}};
    });
    expectError([&] { capture::openFrameSource(header.string()); }, {kHeader, std::nullopt, "not unit length"});

    const auto tum = makeTum("bad_quaternion_tum");
    std::ofstream(tum / "groundtruth.txt") << "1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0.5 0.5\n";
    expectError([&] { capture::openFrameSource(tum.string()); },
                {"groundtruth.txt", std::nullopt, "line 2: quaternion is not unit length"});
}

TEST(MalformedInputTest, LinesAfterTheEndMarker) {
    const auto folder = makeRecording("bad_after_end");
    auto lines = readLines(folder / kIndex);
    ASSERT_EQ(lines.size(), 4u); // 3 frames + {"end":true,...}
    ASSERT_NE(lines.back().find("\"end\":true"), std::string::npos);
    lines.push_back(lines.at(0));
    writeLines(folder / kIndex, lines);
    expectError([&] { capture::openFrameSource(folder.string()); }, {kIndex, 3, "lines after the end marker"});

    // An end marker that is not one (a json type error unless the reader checks the type).
    auto marker = lines;
    marker.pop_back();
    marker.back() = R"({"end":"yes","frames":3})";
    writeLines(folder / kIndex, marker);
    expectError([&] { capture::openFrameSource(folder.string()); }, {kIndex, 3, "'end' must be true"});

    // An end marker whose count differs from the lines before it (a frame line lost).
    lines.pop_back();
    lines.erase(lines.begin() + 1);
    writeLines(folder / kIndex, lines);
    editIndexLine(folder, 1, [](json& line) { line["frame"] = 1; });
    expectError([&] { capture::openFrameSource(folder.string()); },
                {kIndex, std::nullopt, "the end marker counts 3 frames, the index holds 2"});
}

TEST(MalformedInputTest, OverLongIndexLine) {
    // The limit is 64 KiB per line (RecordingFormat.h); a real line is ~300 bytes.
    const auto folder = makeRecording("bad_long_line");
    editIndexLine(folder, 1, [](json& line) { line["padding"] = std::string(70 * 1024, 'x'); });
    expectError([&] { capture::openFrameSource(folder.string()); }, {kIndex, 1, "more than the 65536 accepted"});
}

TEST(MalformedInputTest, RegisteredStreamsOfDifferentSizes) {
    const auto folder = makeRecording("bad_registered_sizes");
    editHeader(folder, [](json& header) { header["depth"]["width"] = 16; });
    expectError([&] { capture::openFrameSource(folder.string()); },
                {kHeader, std::nullopt, "registered to colour but the two streams' sizes differ"});
}

TEST(MalformedInputTest, DepthScaleNotPositive) {
    for (const double scale : {0.0, -0.001}) {
        const auto folder = makeRecording(scale == 0.0 ? "bad_scale_zero" : "bad_scale_negative");
        editHeader(folder, [&](json& header) { header["depthScaleMetres"] = scale; });
        expectError([&] { capture::openFrameSource(folder.string()); },
                    {kHeader, std::nullopt, "'depthScaleMetres' must be positive"});
        const auto tum = makeTum(scale == 0.0 ? "bad_scale_tum_zero" : "bad_scale_tum_negative");
        std::ofstream(tum / "lightskin-camera.json", std::ios::trunc) << json{{"depthScaleMetres", scale}}.dump();
        expectError([&] { capture::openFrameSource(tum.string()); },
                    {"lightskin-camera.json", std::nullopt, "'depthScaleMetres' must be a positive number"});
    }
    // Explicitly refused too: an option of zero (the command line's --depth-scale).
    capture::FrameSourceOptions options;
    options.depthScaleMetres = 0.0;
    const auto tum = makeTum("bad_scale_option");
    expectError([&] { capture::openFrameSource(tum.string(), options); },
                {"bad_scale_option", std::nullopt, "depth scale must be positive"});
}

TEST(MalformedInputTest, MalformedCameraSidecar) {
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"{\"colour\": {\"width\": 32,", "malformed JSON"},
        {"[1, 2, 3]", "must be a JSON object"},
        {R"({"colour": {"width": 32, "height": 24, "fx": "thirty", "fy": 30, "cx": 15.5, "cy": 11.5}})",
         "'fx' is missing or not a number"},
        {R"({"colour": [32, 24]})", "'colour' must be an object"},
        {R"({"depthScaleMetres": "0.001"})", "'depthScaleMetres' must be a positive number"},
        {R"({"device": 5})", "'device' must be a string"},
    };
    for (std::size_t i = 0; i < cases.size(); ++i) {
        const auto tum = makeTum("bad_sidecar_" + std::to_string(i));
        std::ofstream(tum / "lightskin-camera.json", std::ios::trunc) << cases[i].first;
        expectError([&] { capture::openFrameSource(tum.string()); },
                    {"lightskin-camera.json", std::nullopt, cases[i].second});
    }
}

TEST(MalformedInputTest, SeekOutOfRange) {
    const auto folder = makeRecording("bad_seek");
    auto recording = capture::openFrameSource(folder.string());
    ASSERT_EQ(recording->frameCount(), std::optional<std::int64_t>(3));
    expectError([&] { recording->seek(3); }, {"rec", 3, "seek outside the source (3 frames)"});
    expectError([&] { recording->seek(-1); }, {"rec", -1, "seek outside the source (3 frames)"});
    // The source is still usable after a refused seek.
    recording->seek(2);
    RgbdFrame frame;
    ASSERT_TRUE(recording->next(frame));
    EXPECT_EQ(frame.index, 2);

    const auto tum = makeTum("bad_seek_tum");
    auto tumSource = capture::openFrameSource(tum.string());
    expectError([&] { tumSource->seek(2); }, {"bad_seek_tum", 2, "seek outside the source (2 frames)"});
}

TEST(MalformedInputTest, ZeroByteImageFiles) {
    const auto folder = makeRecording("bad_zero_byte");
    std::filesystem::resize_file(folder / "colour" / "000001.png", 0);
    expectError([&] { readAll(folder); }, {"000001.png", 1, "file is empty (0 bytes)"});

    const auto tum = makeTum("bad_zero_byte_tum");
    std::filesystem::resize_file(tum / "d.png", 0);
    expectError([&] { readAll(tum); }, {"d.png", 0, "file is empty (0 bytes)"});
}

TEST(MalformedInputTest, SixteenBitAndRgbaColourAreConvertedNotRefused) {
    // Decided behaviour: colour is 8-bit BGR in memory. A 16-bit colour image keeps its high byte
    // (libpng's 16->8 reduction; 0x12ff may round to 0x13), an alpha channel is dropped; both are
    // valid camera images, so they are read, not refused. Asserted by value so that a silent
    // change (e.g. reading the low byte, or the alpha as blue) fails.
    const auto tum = makeTum("colour_16bit_rgba");
    cv::imwrite((tum / "c16.png").string(), cv::Mat(24, 32, CV_16UC3, cv::Scalar(0x12ff, 0x3400, 0xab00)));
    cv::imwrite((tum / "c4.png").string(), cv::Mat(24, 32, CV_8UC4, cv::Scalar(10, 20, 30, 128)));
    std::ofstream(tum / "rgb.txt", std::ios::trunc) << "1.0 c16.png\n2.0 c4.png\n";
    auto source = capture::openFrameSource(tum.string());
    RgbdFrame frame;
    ASSERT_TRUE(source->next(frame));
    ASSERT_EQ(frame.colour.type(), CV_8UC3);
    const auto sixteen = frame.colour.at<cv::Vec3b>(5, 7);
    EXPECT_TRUE(sixteen[0] == 0x12 || sixteen[0] == 0x13) << int(sixteen[0]);
    EXPECT_EQ(sixteen[1], 0x34);
    EXPECT_EQ(sixteen[2], 0xab);
    ASSERT_TRUE(source->next(frame));
    ASSERT_EQ(frame.colour.type(), CV_8UC3);
    EXPECT_EQ(frame.colour.at<cv::Vec3b>(5, 7), cv::Vec3b(10, 20, 30));
    // 16-bit colour is refused as depth, and colour is refused where depth is expected.
    std::ofstream(tum / "depth.txt", std::ios::trunc) << "1.0 c16.png\n";
    expectError([&] { readAll(tum); }, {"c16.png", 0, "depth must be 16-bit single-channel"});
}

TEST(MalformedInputTest, AbsentFreenectDevice) {
    // The real libfreenect (no Kinect on a test machine, index 7 in any case): either USB works and
    // no device has that index, or libusb cannot start at all (a container without USB). Both
    // messages name the URI and say which.
    try {
        capture::openFrameSource("freenect://7");
        ADD_FAILURE() << "freenect://7 opened";
    } catch (const Error& error) {
        EXPECT_EQ(error.source(), "freenect://7");
        EXPECT_FALSE(error.frame().has_value());
        const bool noSuchIndex = error.cause().find("no Kinect v1 with index 7 (") != std::string::npos;
        const bool noUsb = error.cause().find("libfreenect initialisation failed") != std::string::npos;
        EXPECT_TRUE(noSuchIndex || noUsb) << error.what();
    }
}

} // namespace
} // namespace lightskin::test
