#include "ImageIo.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/ImageFile.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <unistd.h>

namespace lightskin::capture::detail {

namespace {

std::string sizeText(cv::Size size) { return std::to_string(size.width) + "x" + std::to_string(size.height); }

void decodeInto(const std::filesystem::path& path, std::optional<std::int64_t> frame, int flags,
                const std::vector<unsigned char>& bytes, std::optional<cv::Size> expected, const char* what,
                cv::Mat& out) {
    // OpenCV reports an empty buffer as a failed assertion: say what it means.
    if (bytes.empty()) throw Error(path.string(), frame, "file is empty (0 bytes)");
    // Only PNG, TIFF and JPEG reach cv::imdecode: on other bytes it tries every decoder OpenCV has,
    // and Debian's GDCM (DICOM) aborts the process on an assertion (a fuzz finding).
    const std::optional<cv::Size> headerSize = peekImageSize(bytes, path, frame);
    if (!headerSize) throw Error(path.string(), frame, "not a PNG, TIFF or JPEG file");
    // The size in the header is checked before the decoder allocates anything for it.
    if (expected && *headerSize != *expected)
        throw Error(path.string(), frame,
                    std::string(what) + " image is " + sizeText(*headerSize) + ", expected " + sizeText(*expected));
    try {
        cv::imdecode(bytes, flags, &out);
    } catch (const cv::Exception& error) {
        throw Error(path.string(), frame, std::string("cannot decode the image: ") + error.what());
    }
    if (out.empty())
        throw Error(path.string(), frame, "cannot decode the image (truncated, corrupt or unknown format)");
}

} // namespace

std::string describeMatType(int type) {
    const int depth = CV_MAT_DEPTH(type);
    const char* names[] = {"8-bit unsigned", "8-bit signed", "16-bit unsigned", "16-bit signed",
                           "32-bit signed",  "32-bit float", "64-bit float",    "16-bit float"};
    return std::string(depth >= 0 && depth < 8 ? names[depth] : "unknown") + " " + std::to_string(CV_MAT_CN(type)) +
           "-channel";
}

void readFileBounded(const std::filesystem::path& path, std::optional<std::int64_t> frame, std::uintmax_t maxBytes,
                     std::vector<unsigned char>& bytes) {
    std::error_code error;
    const auto status = std::filesystem::status(path, error);
    if (error || !std::filesystem::exists(status)) throw Error(path.string(), frame, "file is missing");
    if (!std::filesystem::is_regular_file(status)) throw Error(path.string(), frame, "not a regular file");
    const std::uintmax_t size = std::filesystem::file_size(path, error);
    if (error) throw Error(path.string(), frame, "cannot read the file size: " + error.message());
    if (size > maxBytes)
        throw Error(path.string(), frame,
                    "file is " + std::to_string(size) + " bytes, more than the " + std::to_string(maxBytes) +
                        " accepted");
    std::ifstream stream(path, std::ios::binary);
    if (!stream) throw Error(path.string(), frame, "cannot open the file");
    bytes.resize(size);
    stream.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(size));
    if (static_cast<std::uintmax_t>(stream.gcount()) != size)
        throw Error(path.string(), frame, "cannot read the whole file");
}

void readDepth16(const std::filesystem::path& path, std::optional<std::int64_t> frame, std::optional<cv::Size> expected,
                 std::vector<unsigned char>& scratch, cv::Mat& out) {
    readFileBounded(path, frame, kMaxImageFileBytes, scratch);
    decodeInto(path, frame, cv::IMREAD_UNCHANGED, scratch, expected, "depth", out);
    if (out.type() != CV_16UC1)
        throw Error(path.string(), frame,
                    "depth must be 16-bit single-channel, the file holds " + describeMatType(out.type()) + " pixels");
    if (expected && out.size() != *expected)
        throw Error(path.string(), frame,
                    "depth image is " + sizeText(out.size()) + ", expected " + sizeText(*expected));
}

void readColour8(const std::filesystem::path& path, std::optional<std::int64_t> frame, std::optional<cv::Size> expected,
                 std::vector<unsigned char>& scratch, cv::Mat& out) {
    readFileBounded(path, frame, kMaxImageFileBytes, scratch);
    decodeInto(path, frame, cv::IMREAD_COLOR, scratch, expected, "colour", out);
    if (out.type() != CV_8UC3)
        throw Error(path.string(), frame, "colour must decode to 8-bit 3-channel, got " + describeMatType(out.type()));
    if (expected && out.size() != *expected)
        throw Error(path.string(), frame,
                    "colour image is " + sizeText(out.size()) + ", expected " + sizeText(*expected));
}

void writeFileAtomically(const std::filesystem::path& path, std::optional<std::int64_t> frame,
                         const std::vector<unsigned char>& bytes, bool durable) {
    const std::string temporary = path.string() + ".tmp";
    const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) throw Error(temporary, frame, std::string("cannot create the file: ") + std::strerror(errno));
    std::size_t written = 0;
    while (written < bytes.size()) {
        const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            const int code = errno;
            ::close(fd);
            ::unlink(temporary.c_str());
            throw Error(temporary, frame, std::string("cannot write the file: ") + std::strerror(code));
        }
        written += static_cast<std::size_t>(n);
    }
    while (durable && ::fsync(fd) != 0) {
        if (errno == EINTR) continue;
        const int code = errno;
        ::close(fd);
        ::unlink(temporary.c_str());
        throw Error(temporary, frame, std::string("cannot fsync the file: ") + std::strerror(code));
    }
    if (::close(fd) != 0) {
        const int code = errno;
        ::unlink(temporary.c_str());
        throw Error(temporary, frame, std::string("cannot close the file: ") + std::strerror(code));
    }
    if (std::rename(temporary.c_str(), path.c_str()) != 0) {
        const int code = errno;
        ::unlink(temporary.c_str());
        throw Error(path.string(), frame,
                    std::string("cannot rename the finished file into place: ") + std::strerror(code));
    }
}

std::filesystem::path resolveInside(const std::filesystem::path& folder, const std::string& relative,
                                    const std::filesystem::path& listFile, std::optional<std::int64_t> frame) {
    const std::filesystem::path name(relative);
    if (relative.empty()) throw Error(listFile.string(), frame, "empty file name");
    if (name.is_absolute() || name.has_root_name() || name.has_root_directory())
        throw Error(listFile.string(), frame,
                    "file name '" + relative + "' is absolute: refused (must stay inside the folder)");
    for (const auto& part : name.lexically_normal())
        if (part == "..")
            throw Error(listFile.string(), frame, "file name '" + relative + "' leaves the folder: refused");
    const std::filesystem::path joined = folder / name.lexically_normal();
    // A symbolic link inside the folder could still point outside: compare canonical paths.
    std::error_code error;
    const std::filesystem::path canonicalFolder = std::filesystem::weakly_canonical(folder, error);
    const std::filesystem::path canonicalFile = std::filesystem::weakly_canonical(joined, error);
    if (!error) {
        const auto rel = canonicalFile.lexically_relative(canonicalFolder);
        if (rel.empty() || *rel.begin() == "..")
            throw Error(listFile.string(), frame, "file name '" + relative + "' resolves outside the folder: refused");
    }
    return joined;
}

} // namespace lightskin::capture::detail
