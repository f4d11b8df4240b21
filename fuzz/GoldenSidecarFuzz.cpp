// Fuzz target: a golden image (16-bit PNG + JSON sidecar) through eval::readLinearPng16. The first
// input byte picks the file that receives the rest: even = the sidecar (beside a fixed valid
// 4x3 16-bit PNG), odd = the PNG (beside a fixed valid sidecar).
#include "FuzzSupport.h"

#include <lightskin/core/Error.h>
#include <lightskin/eval/GoldenImage.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    static const lightskin::fuzz::ScratchFolder folder("golden");
    static const std::vector<unsigned char> validPng = [] {
        std::vector<unsigned char> bytes;
        cv::imencode(".png", cv::Mat(3, 4, CV_16UC3, cv::Scalar(100, 2000, 30000)), bytes);
        return bytes;
    }();
    const auto png = folder.path() / "golden.png", sidecar = folder.path() / "golden.json";
    if (data[0] % 2 == 0) {
        lightskin::fuzz::writeFile(png, validPng.data(), validPng.size());
        lightskin::fuzz::writeFile(sidecar, data + 1, size - 1);
    } else {
        lightskin::fuzz::writeFile(png, data + 1, size - 1);
        lightskin::fuzz::writeFile(sidecar, "{\"renderer\":\"fuzz\",\"linearPeak\":1.0}");
    }
    try {
        std::string renderer;
        double linearPeak = 0.0;
        (void)lightskin::eval::readLinearPng16(png, renderer, linearPeak);
    } catch (const lightskin::Error&) {
    }
    return 0;
}
