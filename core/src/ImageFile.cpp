#include <lightskin/core/Error.h>
#include <lightskin/core/ImageFile.h>

#include <opencv2/imgcodecs.hpp>

#include <cstring>
#include <fstream>

namespace lightskin {

namespace {

std::uint32_t readBigEndian32(const unsigned char* p) {
    return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
}

std::uint32_t readTiff32(const unsigned char* p, bool littleEndian) {
    return littleEndian ? (std::uint32_t{p[3]} << 24) | (std::uint32_t{p[2]} << 16) | (std::uint32_t{p[1]} << 8) | p[0]
                        : readBigEndian32(p);
}

std::uint16_t readTiff16(const unsigned char* p, bool littleEndian) {
    return static_cast<std::uint16_t>(littleEndian ? (p[1] << 8) | p[0] : (p[0] << 8) | p[1]);
}

void checkSide(std::uint64_t width, std::uint64_t height, const std::filesystem::path& path,
               std::optional<std::int64_t> frame) {
    if (width == 0 || height == 0 || width > std::uint64_t(kMaxImageSide) || height > std::uint64_t(kMaxImageSide))
        throw Error(path.string(), frame,
                    "image header states an absurd size " + std::to_string(width) + "x" + std::to_string(height) +
                        " (accepted: 1.." + std::to_string(kMaxImageSide) + " per side)");
}

} // namespace

std::optional<cv::Size> peekImageSize(const std::vector<unsigned char>& bytes, const std::filesystem::path& path,
                                      std::optional<std::int64_t> frame) {
    static constexpr unsigned char pngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (bytes.size() >= 8 && std::memcmp(bytes.data(), pngSignature, 8) == 0) {
        if (bytes.size() < 33 || std::memcmp(bytes.data() + 12, "IHDR", 4) != 0)
            throw Error(path.string(), frame, "truncated PNG: no complete IHDR header");
        const std::uint32_t width = readBigEndian32(bytes.data() + 16), height = readBigEndian32(bytes.data() + 20);
        checkSide(width, height, path, frame);
        return cv::Size(int(width), int(height));
    }
    if (bytes.size() >= 3 && bytes[0] == 0xff && bytes[1] == 0xd8 && bytes[2] == 0xff) {
        // JPEG: walk the marker segments to the start-of-frame (SOFn) header.
        std::size_t at = 2;
        while (at + 4 <= bytes.size()) {
            if (bytes[at] != 0xff) break;
            const unsigned char marker = bytes[at + 1];
            if (marker == 0xff) { // fill byte
                ++at;
                continue;
            }
            const std::size_t length = std::size_t(bytes[at + 2]) << 8 | bytes[at + 3];
            const bool startOfFrame =
                marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc;
            if (startOfFrame) {
                if (at + 9 > bytes.size()) break;
                const std::uint64_t height = std::uint64_t(bytes[at + 5]) << 8 | bytes[at + 6];
                const std::uint64_t width = std::uint64_t(bytes[at + 7]) << 8 | bytes[at + 8];
                checkSide(width, height, path, frame);
                return cv::Size(int(width), int(height));
            }
            if (length < 2) break;
            at += 2 + length;
        }
        throw Error(path.string(), frame, "truncated or corrupt JPEG: no frame header");
    }
    const bool little = bytes.size() >= 4 && bytes[0] == 'I' && bytes[1] == 'I' && bytes[2] == 42 && bytes[3] == 0;
    const bool big = bytes.size() >= 4 && bytes[0] == 'M' && bytes[1] == 'M' && bytes[2] == 0 && bytes[3] == 42;
    if (!little && !big) return std::nullopt;
    if (bytes.size() < 8) throw Error(path.string(), frame, "truncated TIFF header");
    const std::uint64_t ifd = readTiff32(bytes.data() + 4, little);
    if (ifd + 2 > bytes.size())
        throw Error(path.string(), frame, "truncated TIFF: first directory beyond the end of the file");
    const std::uint16_t entries = readTiff16(bytes.data() + ifd, little);
    if (ifd + 2 + std::uint64_t(entries) * 12 > bytes.size())
        throw Error(path.string(), frame, "truncated TIFF: directory runs past the end of the file");
    std::uint64_t width = 0, height = 0;
    for (std::uint16_t i = 0; i < entries; ++i) {
        const unsigned char* entry = bytes.data() + ifd + 2 + std::uint64_t(i) * 12;
        const std::uint16_t tag = readTiff16(entry, little), type = readTiff16(entry + 2, little);
        const std::uint64_t value = type == 3 ? readTiff16(entry + 8, little) : readTiff32(entry + 8, little);
        if (tag == 256) width = value;
        if (tag == 257) height = value;
    }
    checkSide(width, height, path, frame);
    return cv::Size(int(width), int(height));
}

cv::Mat readImageFile(const std::filesystem::path& path, int flags) {
    const std::string file = path.string();
    std::error_code error;
    if (!std::filesystem::is_regular_file(path, error)) throw Error(file, std::nullopt, "image file is missing");
    const std::uintmax_t size = std::filesystem::file_size(path, error);
    if (error) throw Error(file, std::nullopt, "cannot read the file size: " + error.message());
    if (size == 0) throw Error(file, std::nullopt, "file is empty (0 bytes)");
    if (size > kMaxImageFileBytes)
        throw Error(file, std::nullopt,
                    "file is " + std::to_string(size) + " bytes, more than the " + std::to_string(kMaxImageFileBytes) +
                        " accepted");
    std::vector<unsigned char> bytes(size);
    std::ifstream stream(path, std::ios::binary);
    stream.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(size));
    if (!stream || static_cast<std::uintmax_t>(stream.gcount()) != size)
        throw Error(file, std::nullopt, "cannot read the whole file");
    if (!peekImageSize(bytes, path, std::nullopt)) throw Error(file, std::nullopt, "not a PNG, TIFF or JPEG file");
    cv::Mat image;
    try {
        image = cv::imdecode(bytes, flags);
    } catch (const cv::Exception& decodeError) {
        throw Error(file, std::nullopt, std::string("cannot decode the image: ") + decodeError.what());
    }
    if (image.empty()) throw Error(file, std::nullopt, "cannot decode the image (truncated or corrupt)");
    return image;
}

} // namespace lightskin
