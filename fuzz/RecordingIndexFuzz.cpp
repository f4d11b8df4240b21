// Fuzz target: the recording frame index (frames.jsonl) through openFrameSource, with a fixed
// valid 8x6 header and real 8x6 images c.png (colour) and d.png (16-bit depth) that index lines
// may name; reads every frame, then seeks to the last one.
#include "FuzzSupport.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace {

const lightskin::fuzz::ScratchFolder& folder() {
    static const lightskin::fuzz::ScratchFolder scratch("recording-index");
    return scratch;
}

void writeFixedFiles(const std::filesystem::path& root) {
    static bool written = false;
    if (written) return;
    written = true;
    const char* intrinsics = "{\"width\":8,\"height\":6,\"fx\":10,\"fy\":10,\"cx\":3.5,\"cy\":2.5}";
    lightskin::fuzz::writeFile(root / "lightskin-recording.json",
                               std::string("{\"format\":\"lightskin-recording\",\"version\":1,\"device\":\"fuzz\","
                                           "\"colour\":") +
                                   intrinsics + ",\"depth\":" + intrinsics +
                                   ",\"depthScaleMetres\":0.001,\"registration\":\"registered-to-colour\"}");
    cv::imwrite((root / "c.png").string(), cv::Mat(6, 8, CV_8UC3, cv::Scalar(10, 20, 30)));
    cv::imwrite((root / "d.png").string(), cv::Mat(6, 8, CV_16UC1, cv::Scalar(1000)));
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const auto& root = folder().path();
    writeFixedFiles(root);
    lightskin::fuzz::writeFile(root / "frames.jsonl", data, size);
    try {
        auto source = lightskin::capture::openFrameSource(root.string());
        lightskin::RgbdFrame frame;
        while (source->next(frame)) {
        }
        if (const auto count = source->frameCount(); count && *count > 0 && source->canSeek()) {
            source->seek(*count - 1);
            source->next(frame);
        }
    } catch (const lightskin::Error&) {
    }
    return 0;
}
