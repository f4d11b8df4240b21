#pragma once
// Image files from untrusted places (recordings, scene textures, goldens) through one guard: only
// PNG, TIFF and JPEG reach OpenCV's decoders, and only after their header's size was checked. On
// other bytes cv::imread/imdecode try every decoder OpenCV has, and Debian's GDCM (DICOM) aborts
// the process on an assertion (a fuzz finding); a forged size would allocate before any check.

#include <opencv2/core/mat.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <vector>

namespace lightskin {

/// Largest image side accepted (pixels) and largest image file (bytes).
inline constexpr int kMaxImageSide = 16384;
inline constexpr std::uintmax_t kMaxImageFileBytes = std::uintmax_t{256} << 20;

/// Width and height from a PNG, TIFF or JPEG header, when `bytes` is one of those (nullopt for other
/// formats). Throws lightskin::Error (path, frame, cause) when the header is truncated or states an
/// absurd size.
std::optional<cv::Size> peekImageSize(const std::vector<unsigned char>& bytes, const std::filesystem::path& path,
                                      std::optional<std::int64_t> frame);

/// Reads and decodes a PNG, TIFF or JPEG file with cv::IMREAD_* `flags`. Throws lightskin::Error
/// naming the file and the cause when it is missing, empty, larger than kMaxImageFileBytes, another
/// format ("not a PNG, TIFF or JPEG file"), states an absurd size or does not decode.
cv::Mat readImageFile(const std::filesystem::path& path, int flags);

} // namespace lightskin
