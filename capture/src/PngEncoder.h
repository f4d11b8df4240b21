#pragma once
// PNG encoding for the recorder's hot path, through libpng directly rather than cv::imencode:
// OpenCV lets libpng try all five row filters per row (adaptive filtering), which is half of the
// encoder's time; one fixed filter (Up) with zlib level 1 and the RLE strategy costs about half the
// CPU for files within ~5 % of the size (measured on camera-like 640x480 frames: 24 ms -> 12 ms per
// colour + depth pair; docs/BENCHMARKS.md "Recorder under load"). The output is ordinary PNG: any
// reader, ours included, decodes it unchanged.

#include <opencv2/core/mat.hpp>

#include <vector>

namespace lightskin::capture::detail {

/// Encodes an 8-bit BGR (CV_8UC3) or 16-bit grey (CV_16UC1) image as PNG into `out` (its capacity is
/// kept between calls: no allocation by `out` once it has grown to a frame's worst case). Throws
/// lightskin::Error on another pixel type or when libpng fails.
void encodePngFast(const cv::Mat& image, std::vector<unsigned char>& out);

} // namespace lightskin::capture::detail
