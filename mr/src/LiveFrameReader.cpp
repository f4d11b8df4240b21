#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/mr/LiveFrameReader.h>

#include <cstdio>

namespace lightskin::mr {

namespace {
std::string seconds(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.1f s", value);
    return text;
}
} // namespace

LiveFrameReader::LiveFrameReader(capture::FrameSource& source, const LiveFrameReaderOptions& options)
    : source_(source)
    , options_(options)
    , lastFrame_(std::chrono::steady_clock::now()) {}

LiveFrameReader::Result LiveFrameReader::next(RgbdFrame& out) {
    try {
        if (!source_.next(out)) return Result::Ended;
    } catch (const capture::SourceStalled& stall) {
        const double missing = std::chrono::duration<double>(std::chrono::steady_clock::now() - lastFrame_).count();
        if (!stalled_) {
            stalled_ = true;
            ++stalls_;
            log::warning(std::string(stall.what()) + "; waiting for frames");
        }
        if (options_.giveUpSeconds <= 0.0 || missing > options_.giveUpSeconds)
            throw Error(stall.source(), stall.frame(),
                        stall.cause() + "; gave up after " + seconds(missing) + " without a frame");
        status_ = "camera: no frame for " + seconds(missing) + " (" + stall.cause() + "); waiting for it";
        framesSinceRecovery_ = -1;
        return Result::Stalled;
    }
    const auto now = std::chrono::steady_clock::now();
    if (stalled_) {
        stalled_ = false;
        status_ = "camera: frames again after a " + seconds(std::chrono::duration<double>(now - lastFrame_).count()) +
                  " stall";
        log::info(status_);
        framesSinceRecovery_ = 0;
    } else if (framesSinceRecovery_ >= 0 && ++framesSinceRecovery_ >= options_.recoveredFrames) {
        framesSinceRecovery_ = -1;
        status_.clear();
    }
    lastFrame_ = now;
    return Result::Frame;
}

} // namespace lightskin::mr
