#pragma once
// Pairs the depth and colour frames of an .oni recording by OpenNI2's frame numbers (internal to capture;
// tests/capture/FramePairingTest.cpp).
//
// OpenNI2's player can skip a frame of one stream (seen under ThreadSanitizer's slowdown: colour went
// 5 -> 7 while depth went on 6, 7; docs/TESTING.md). Taking whatever arrives next would pair depth N with
// colour N + 1 from there on. A recording numbers both streams with the device's frame counter (our Kinect
// v1 sample: 1..12 on both), so a depth and a colour frame belong together when their numbers differ by the
// same amount as the first pair's (0 there; a constant offset is kept for recordings that number the streams
// apart). A frame whose partner has already been passed is dropped, and the source reads the next frame of
// that stream. Live devices number their streams independently, so this applies to files only.
#include <optional>

namespace lightskin::capture::detail {

class FrameIndexPairing {
public:
    enum class Decision {
        Pair,       ///< the held depth and colour frames belong together
        DropDepth,  ///< the held depth frame's colour was skipped: read the next depth frame
        DropColour, ///< the held colour frame's depth was skipped: read the next colour frame
    };

    /// Decides for the held depth frame number `depthIndex` and colour frame number `colourIndex`
    /// (OpenNI2's VideoFrameRef::getFrameIndex). The first call learns the offset and pairs.
    Decision decide(int depthIndex, int colourIndex) {
        const long long difference = static_cast<long long>(colourIndex) - depthIndex;
        if (!offset_) offset_ = difference;
        if (difference == *offset_) return Decision::Pair;
        // Colour is ahead of this depth frame's partner: that colour frame is gone.
        return difference > *offset_ ? Decision::DropDepth : Decision::DropColour;
    }

    /// Forgets the offset (the file is played again from its start).
    void reset() noexcept { offset_.reset(); }

private:
    std::optional<long long> offset_; // colour number - depth number of the first pair
};

} // namespace lightskin::capture::detail
