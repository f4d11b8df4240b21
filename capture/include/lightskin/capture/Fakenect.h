#pragma once
// Writes the dump format of libfreenect's `fakenect` (Debian libfreenect-bin): a folder with
// INDEX.txt and one file per stream frame, `d-<seconds>-<timestamp>-depth.pgm` (one-line header
// "P5 640 480 65535", then 640x480 uint16 in host byte order, as fakenect-record writes it) and
// `r-<seconds>-<timestamp>-rgb.ppm` ("P6 640 480 255", then RGB bytes). Running a libfreenect
// program with LD_LIBRARY_PATH=/usr/lib/x86_64-linux-gnu/fakenect and FAKENECT_PATH=<folder>
// replays the dump through libfreenect's API (`fakenect <folder> <program>` does exactly that),
// which is how the live freenect:// code path is tested without a Kinect.
//
// Depth is stored as the Kinect's raw 11-bit disparity, as a real Kinect dump holds it (Debian's
// fakenect 0.5.3 offers only FREENECT_DEPTH_11BIT and hands the stored pixels over unchanged):
// d = round((1/z[m] - 3.3309495161) / -0.0030711016), the inverse of the calibration the
// freenect:// source applies; 2047 = missing (depth 0, closer than 0.3 m or beyond 10 m). The
// round trip therefore quantises depth to the Kinect's disparity steps (about 3 mm at 1 m,
// 0.5 * 0.00307 * z^2 metres at most), as a real Kinect would. Colour is exact.

#include <lightskin/capture/FrameSource.h>

#include <cstdint>
#include <filesystem>

namespace lightskin::capture {

/// Writes up to `maxFrames` frames of `source` (all when negative) into a new fakenect dump
/// folder. Frames must be 640x480 (fakenect's only resolution) with both images present; pixel
/// positions are kept (registered depth is replayed as if it were the IR camera's). Returns the frames written. Throws
/// lightskin::Error naming the source or folder, the frame and the cause.
std::int64_t writeFakenectDump(FrameSource& source, const std::filesystem::path& folder, std::int64_t maxFrames = -1);

} // namespace lightskin::capture
