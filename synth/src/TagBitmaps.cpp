#include <lightskin/synth/SceneRenderer.h>
#include <lightskin/tracking/TagFamily.h>

namespace lightskin::synth {

// The real bit patterns of Debian's libapriltag, through lightskin::tracking.
TagBitmapSource apriltagBitmaps() {
    return [](const std::string& family, int id) {
        const tracking::TagLayout layout = tracking::tagLayout(family);
        TagBitmap bitmap;
        bitmap.cells = tracking::renderTagBitmap(family, id);
        bitmap.borderStartCell = layout.blackBorderStartCell;
        bitmap.borderCells = layout.blackBorderCells;
        return bitmap;
    };
}

} // namespace lightskin::synth
