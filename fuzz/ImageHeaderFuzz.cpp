// Fuzz target: the PNG/TIFF/JPEG header guard and the checked decoders of the recorded sources
// (capture/src/ImageIo.cpp): peekImageSize in memory, then the same bytes as a colour and a depth
// file with an expected size of 8x6, as a recording or TUM folder reads them.
#include "FuzzSupport.h"
#include "ImageIo.h"

#include <lightskin/core/Error.h>

#include <opencv2/core.hpp>

#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const lightskin::fuzz::ScratchFolder folder("image");
    namespace detail = lightskin::capture::detail;
    const std::vector<unsigned char> bytes(data, data + size);
    const auto file = folder.path() / "image";
    try {
        (void)detail::peekImageSize(bytes, file, 0);
    } catch (const lightskin::Error&) {
    }
    lightskin::fuzz::writeFile(file, data, size);
    std::vector<unsigned char> scratch;
    cv::Mat image;
    try {
        detail::readColour8(file, 0, cv::Size(8, 6), scratch, image);
    } catch (const lightskin::Error&) {
    }
    try {
        detail::readDepth16(file, 0, cv::Size(8, 6), scratch, image);
    } catch (const lightskin::Error&) {
    }
    return 0;
}
