// Fuzz target: a TUM RGB-D folder (rgb.txt, depth.txt, groundtruth.txt, lightskin-camera.json)
// through openFrameSource. The first input byte picks the file that receives the rest of the
// input (modulo 4); the other three files hold fixed valid contents. 8x6 images 1.png (colour)
// and 1_depth.png exist, so association, ground-truth interpolation and reading all run.
#include "FuzzSupport.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <array>

namespace {

const lightskin::fuzz::ScratchFolder& folder() {
    static const lightskin::fuzz::ScratchFolder scratch("tum");
    return scratch;
}

struct FixedFile {
    const char* name;
    const char* validText;
};
constexpr std::array<FixedFile, 4> kFiles{{
    {"rgb.txt", "# colour\n1.0 1.png\n2.0 1.png\n"},
    {"depth.txt", "1.01 1_depth.png\n2.01 1_depth.png\n"},
    {"groundtruth.txt", "0.9 0 0 0 0 0 0 1\n1.5 0.1 0 0 0 0 0.7071068 0.7071068\n2.1 0.2 0 0 0 0 0 1\n"},
    {"lightskin-camera.json", "{\"colour\":{\"width\":8,\"height\":6,\"fx\":10,\"fy\":10,\"cx\":3.5,\"cy\":2.5},"
                              "\"depthScaleMetres\":0.0002,\"device\":\"fuzz\"}"},
}};

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    const auto& root = folder().path();
    static const bool imagesWritten = [&] {
        cv::imwrite((root / "1.png").string(), cv::Mat(6, 8, CV_8UC3, cv::Scalar(10, 20, 30)));
        cv::imwrite((root / "1_depth.png").string(), cv::Mat(6, 8, CV_16UC1, cv::Scalar(5000)));
        return true;
    }();
    (void)imagesWritten;
    const std::size_t chosen = data[0] % kFiles.size();
    for (std::size_t i = 0; i < kFiles.size(); ++i) {
        if (i == chosen)
            lightskin::fuzz::writeFile(root / kFiles[i].name, data + 1, size - 1);
        else
            lightskin::fuzz::writeFile(root / kFiles[i].name, kFiles[i].validText);
    }
    try {
        auto source = lightskin::capture::openFrameSource(root.string());
        lightskin::RgbdFrame frame;
        while (source->next(frame)) {
        }
    } catch (const lightskin::Error&) {
    }
    return 0;
}
