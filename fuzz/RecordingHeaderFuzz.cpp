// Fuzz target: the recording header (lightskin-recording.json) through openFrameSource, with a
// fixed valid one-frame index beside it, then one frame read.
#include "FuzzSupport.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>

namespace {

const lightskin::fuzz::ScratchFolder& folder() {
    static const lightskin::fuzz::ScratchFolder scratch("recording-header");
    return scratch;
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const auto& root = folder().path();
    lightskin::fuzz::writeFile(
        root / "frames.jsonl",
        "{\"frame\":0,\"colourTime\":0.0,\"depthTime\":0.0,\"colour\":\"c.png\",\"depth\":\"d.png\"}\n"
        "{\"end\":true,\"frames\":1}\n");
    lightskin::fuzz::writeFile(root / "lightskin-recording.json", data, size);
    try {
        auto source = lightskin::capture::openFrameSource(root.string());
        lightskin::RgbdFrame frame;
        source->next(frame); // c.png / d.png do not exist: a clean error after the header checks
    } catch (const lightskin::Error&) {
    }
    return 0;
}
