#include "ImageIo.h"
#include "Sources.h"

#include <lightskin/capture/Fakenect.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/OutputMarker.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

namespace lightskin::capture {

std::int64_t writeFakenectDump(FrameSource& source, const std::filesystem::path& folder, std::int64_t maxFrames) {
    const std::string name = folder.string();
    std::error_code error;
    if (std::filesystem::exists(folder, error) && !isEmptyOutputFolder(folder))
        throw Error(name, std::nullopt, "folder is not empty: refusing to write a fakenect dump into it");
    std::filesystem::create_directories(folder, error);
    if (error) throw Error(name, std::nullopt, "cannot create the folder: " + error.message());
    std::ofstream index(folder / "INDEX.txt");
    if (!index) throw Error((folder / "INDEX.txt").string(), std::nullopt, "cannot create the file");

    RgbdFrame frame;
    cv::Mat millimetres(480, 640, CV_16UC1) /* then disparity */, rgb(480, 640, CV_8UC3);
    std::vector<unsigned char> bytes;
    std::int64_t written = 0;
    double previousTime = std::nan(""), seconds = 1.0;
    while ((maxFrames < 0 || written < maxFrames) && source.next(frame)) {
        const auto fail = [&](const std::string& cause) { throw Error(source.info().uri, frame.index, cause); };
        if (!frame.hasDepth() || !frame.hasColour()) fail("fakenect dumps need both depth and colour in every frame");
        if (frame.depth.size() != cv::Size(640, 480) || frame.colour.size() != cv::Size(640, 480))
            fail("fakenect replays 640x480 only");
        if (std::abs(frame.depthScaleMetres - 0.001) < 1e-12)
            frame.depth.copyTo(millimetres);
        else
            frame.depth.convertTo(millimetres, CV_16U, frame.depthScaleMetres / 0.001); // rounds, saturates
        for (int v = 0; v < 480; ++v) {
            auto* row = millimetres.ptr<std::uint16_t>(v);
            for (int u = 0; u < 640; ++u) row[u] = static_cast<std::uint16_t>(detail::disparityFromMillimetres(row[u]));
        }
        cv::cvtColor(frame.colour, rgb, cv::COLOR_BGR2RGB);

        // fakenect sleeps between index lines by the difference of the <seconds> fields: keep the
        // recorded pace but cap gaps at 1 s, so a recording with a pause cannot stall a replay.
        double time =
            std::isfinite(frame.depthTimestampSeconds) ? frame.depthTimestampSeconds : frame.colourTimestampSeconds;
        if (!std::isfinite(time)) time = std::isfinite(previousTime) ? previousTime + 1.0 / 30.0 : 0.0;
        if (std::isfinite(previousTime)) seconds += std::clamp(time - previousTime, 0.0, 1.0);
        previousTime = time;
        const auto timestamp = static_cast<unsigned>(written);
        char depthName[96], rgbName[96];
        std::snprintf(depthName, sizeof depthName, "d-%.6f-%010u-depth.pgm", seconds, timestamp);
        std::snprintf(rgbName, sizeof rgbName, "r-%.6f-%010u-rgb.ppm", seconds + 1e-6, timestamp);

        static constexpr char depthHeader[] = "P5 640 480 65535\n";
        bytes.assign(depthHeader, depthHeader + std::strlen(depthHeader));
        bytes.insert(bytes.end(), millimetres.data, millimetres.data + millimetres.total() * millimetres.elemSize());
        detail::writeFileAtomically(folder / depthName, frame.index, bytes);
        static constexpr char rgbHeader[] = "P6 640 480 255\n";
        bytes.assign(rgbHeader, rgbHeader + std::strlen(rgbHeader));
        bytes.insert(bytes.end(), rgb.data, rgb.data + rgb.total() * rgb.elemSize());
        detail::writeFileAtomically(folder / rgbName, frame.index, bytes);
        index << depthName << "\n" << rgbName << "\n";
        if (!index) throw Error((folder / "INDEX.txt").string(), frame.index, "cannot write the index");
        ++written;
    }
    index.flush();
    if (!index) throw Error((folder / "INDEX.txt").string(), std::nullopt, "cannot write the index");
    return written;
}

} // namespace lightskin::capture
