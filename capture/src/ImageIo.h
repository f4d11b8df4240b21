#pragma once
// Bounded, checked image file reading shared by the recorded sources. Every failure throws
// lightskin::Error naming the file, the frame and the cause; nothing is allocated for a size
// taken from a file before that size has been checked against the limits below.

#include <lightskin/core/ImageFile.h>

#include <opencv2/core/mat.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace lightskin::capture::detail {

/// Largest image file accepted (bytes) and largest image side (pixels).
using lightskin::kMaxImageFileBytes;
using lightskin::kMaxImageSide;

/// Reads a whole file into `bytes` (reused), refusing files larger than `maxBytes`.
void readFileBounded(const std::filesystem::path& path, std::optional<std::int64_t> frame, std::uintmax_t maxBytes,
                     std::vector<unsigned char>& bytes);

/// Width and height from a PNG, TIFF or JPEG header (lightskin/core/ImageFile.h).
using lightskin::peekImageSize;

/// Decodes a depth image (16-bit single-channel PNG/TIFF) into `out` (reused). Refuses 8-bit,
/// float or multi-channel images, and a size other than `expected` when given.
void readDepth16(const std::filesystem::path& path, std::optional<std::int64_t> frame, std::optional<cv::Size> expected,
                 std::vector<unsigned char>& scratch, cv::Mat& out);

/// Decodes a colour image into 8-bit BGR `out` (reused). Greyscale is expanded to BGR. Refuses a
/// size other than `expected` when given.
void readColour8(const std::filesystem::path& path, std::optional<std::int64_t> frame, std::optional<cv::Size> expected,
                 std::vector<unsigned char>& scratch, cv::Mat& out);

/// Writes `bytes` to `path` through `path.tmp` + rename, so `path` is either absent or complete
/// after a crash. With `durable` the data is fsync'ed before the rename (a power loss then leaves
/// the old or the complete new content; the folder entry still needs an fsync of the folder).
void writeFileAtomically(const std::filesystem::path& path, std::optional<std::int64_t> frame,
                         const std::vector<unsigned char>& bytes, bool durable = false);

/// Resolves `relative` (from a manifest or list) inside `folder`. Throws when it is absolute or
/// would leave the folder (`..`, or a symbolic link pointing outside).
std::filesystem::path resolveInside(const std::filesystem::path& folder, const std::string& relative,
                                    const std::filesystem::path& listFile, std::optional<std::int64_t> frame);

std::string describeMatType(int type);

} // namespace lightskin::capture::detail
