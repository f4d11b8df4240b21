// lightskin::readImageFile, the guard in front of OpenCV's decoders for scene textures and goldens:
// only PNG, TIFF and JPEG are decoded, their header's size is checked
// first, and every refusal names the file and the cause.
#include "TestPaths.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/ImageFile.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <fstream>

namespace lightskin::test {
namespace {

std::string errorOf(const std::filesystem::path& path) {
    try {
        (void)readImageFile(path, cv::IMREAD_UNCHANGED);
    } catch (const Error& error) {
        return error.what();
    }
    return "(no error)";
}

TEST(ImageFileTest, DecodesPngTiffJpegAndRefusesEverythingElseNamingTheFile) {
    const auto folder = scratchDir("image_file");
    cv::Mat image(6, 8, CV_8UC3);
    cv::randu(image, 0, 256);
    for (const char* extension : {".png", ".tiff"}) { // lossless: must read back bit-exact
        const auto path = folder / (std::string("ok") + extension);
        ASSERT_TRUE(cv::imwrite(path.string(), image));
        const cv::Mat back = readImageFile(path, cv::IMREAD_UNCHANGED);
        ASSERT_EQ(back.size(), image.size());
        EXPECT_EQ(cv::norm(back, image, cv::NORM_INF), 0.0) << extension;
    }
    ASSERT_TRUE(cv::imwrite((folder / "ok.jpg").string(), image));
    EXPECT_EQ(readImageFile(folder / "ok.jpg", cv::IMREAD_COLOR).size(), image.size());

    // A BMP (OpenCV would decode it; so it would any other format it has, GDCM's DICOM included).
    ASSERT_TRUE(cv::imwrite((folder / "other.bmp").string(), image));
    const std::string bmp = errorOf(folder / "other.bmp");
    EXPECT_NE(bmp.find("other.bmp"), std::string::npos) << bmp;
    EXPECT_NE(bmp.find("not a PNG, TIFF or JPEG file"), std::string::npos) << bmp;

    std::ofstream(folder / "empty.png").flush();
    EXPECT_NE(errorOf(folder / "empty.png").find("file is empty (0 bytes)"), std::string::npos);
    EXPECT_NE(errorOf(folder / "absent.png").find("image file is missing"), std::string::npos);

    // A PNG whose IHDR claims 100000 x 6 pixels: refused from the header, before any allocation.
    std::string bytes;
    {
        std::ifstream in(folder / "ok.png", std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    bytes[16] = 0, bytes[17] = 1, bytes[18] = char(0x86), bytes[19] = char(0xa0); // width 100000, big-endian
    std::ofstream(folder / "huge.png", std::ios::binary) << bytes;
    const std::string huge = errorOf(folder / "huge.png");
    EXPECT_NE(huge.find("absurd size 100000x6"), std::string::npos) << huge;

    // A PNG cut after its header: the decoder fails, reported as such.
    std::ofstream(folder / "cut.png", std::ios::binary)
        << bytes.substr(0, 40).replace(16, 4, std::string("\0\0\0\x08", 4));
    const std::string cut = errorOf(folder / "cut.png");
    EXPECT_NE(cut.find("cannot decode the image"), std::string::npos) << cut;
}

} // namespace
} // namespace lightskin::test
