#include <lightskin/core/Error.h>
#include <lightskin/core/RgbdFrame.h>

#include <cmath>

namespace lightskin {

const char* toString(DepthRegistration registration) noexcept {
    switch (registration) {
    case DepthRegistration::Unregistered: return "unregistered";
    case DepthRegistration::RegisteredToColour: return "registered-to-colour";
    }
    return "unknown";
}

double RgbdFrame::depthMetresAt(int u, int v) const {
    LIGHTSKIN_ASSERT(u >= 0 && v >= 0 && u < depth.cols && v < depth.rows, "pixel outside the depth image");
    return double(depth.at<std::uint16_t>(v, u)) * depthScaleMetres;
}

RgbdFrame RgbdFrame::clone() const {
    RgbdFrame copy = *this;
    copy.colour = colour.clone();
    copy.depth = depth.clone();
    return copy;
}

void RgbdFrame::validate(const std::string& sourceName) const {
    const auto fail = [&](const std::string& cause) { throw Error(sourceName, index, cause); };
    if (hasColour()) {
        if (colour.type() != CV_8UC3) fail("colour must be 8-bit 3-channel (CV_8UC3), got type " + std::to_string(colour.type()));
        if (colourIntrinsics.isValid() &&
            (colour.cols != colourIntrinsics.width || colour.rows != colourIntrinsics.height))
            fail("colour is " + std::to_string(colour.cols) + "x" + std::to_string(colour.rows) +
                 " but its intrinsics say " + std::to_string(colourIntrinsics.width) + "x" +
                 std::to_string(colourIntrinsics.height));
    }
    if (hasDepth()) {
        if (depth.type() != CV_16UC1) fail("depth must be 16-bit single-channel (CV_16UC1), got type " + std::to_string(depth.type()));
        if (!(depthScaleMetres > 0.0) || !std::isfinite(depthScaleMetres)) fail("depth scale must be positive and finite");
        if (depthIntrinsics.isValid() && (depth.cols != depthIntrinsics.width || depth.rows != depthIntrinsics.height))
            fail("depth is " + std::to_string(depth.cols) + "x" + std::to_string(depth.rows) +
                 " but its intrinsics say " + std::to_string(depthIntrinsics.width) + "x" +
                 std::to_string(depthIntrinsics.height));
    }
    if (registration == DepthRegistration::RegisteredToColour && hasColour() && hasDepth() &&
        colour.size() != depth.size())
        fail("depth is marked registered to colour but the sizes differ (" + std::to_string(depth.cols) + "x" +
             std::to_string(depth.rows) + " vs " + std::to_string(colour.cols) + "x" + std::to_string(colour.rows) + ")");
}

} // namespace lightskin
