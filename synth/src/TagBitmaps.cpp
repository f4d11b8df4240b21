#include <lightskin/core/Error.h>
#include <lightskin/synth/SceneRenderer.h>

namespace lightskin::synth {

// The bit patterns come from Debian's libapriltag through lightskin::tracking; until tracking's
// renderTagBitmap() is available, scenes with tags cannot be rendered with the real patterns.
TagBitmapSource apriltagBitmaps() {
    return [](const std::string& family, int id) -> TagBitmap {
        throw Error(family, std::nullopt,
                    "tag " + std::to_string(id) + ": AprilTag bitmaps need lightskin::tracking::renderTagBitmap (not built yet)");
    };
}

} // namespace lightskin::synth
