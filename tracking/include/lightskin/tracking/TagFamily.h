#pragma once
// AprilTag families as bitmaps: the real bit patterns of Debian's libapriltag 3.3, for texturing
// tags in rendered (synthetic) scenes and for printing.
//
// Cell layout (tag36h11): 10 x 10 cells = 1 white border ring + 1 black border ring + 6 x 6 data
// bits. The "tag size" used everywhere in lightskin (world config, pose) is the edge length of the
// black-border square in metres (AprilTag's convention), NOT the full bitmap including the white ring.
//
// Tag frame (lightskin convention, same as OpenCV's ArUco): origin at the centre of the tag, x to
// the right along the printed tag (bitmap columns), y UP along the printed tag (towards bitmap row
// 0), z out of the printed surface towards a viewer. Units: metres.

#include <opencv2/core/mat.hpp>

#include <string>
#include <vector>

namespace lightskin::tracking {

/// Where the border square that defines the tag size lies in the bitmap of renderTagBitmap().
struct TagLayout {
    /// Edge length of the whole bitmap in cells (tag36h11: 10).
    int totalCells = 0;
    /// First cell (row and column) of the border square (tag36h11: 1).
    int blackBorderStartCell = 0;
    /// Edge length of the border square in cells; the tag size is the edge length of these cells
    /// in metres (tag36h11: 8). For "reversed border" families (tagStandard41h12, tagStandard52h13,
    /// tagCircle*, tagCustom48h12) this square is where the border's colour flips (white inside,
    /// black outside): the edge the detector fits, i.e. again what the tag size measures.
    int blackBorderCells = 0;
    /// Size of one cell in metres for a tag whose tag size is `tagSizeMetres`.
    double cellSizeMetres(double tagSizeMetres) const noexcept {
        return tagSizeMetres / static_cast<double>(blackBorderCells);
    }
};

/// The default family, "tag36h11".
inline constexpr const char* defaultTagFamily = "tag36h11";

/// Family names the library supports (tag36h11, tag36h10, tag25h9, tag16h5, tagCircle21h7,
/// tagCircle49h12, tagCustom48h12, tagStandard41h12, tagStandard52h13).
std::vector<std::string> supportedTagFamilies();

/// Number of distinct ids in `family` (tag36h11: 587). Throws lightskin::Error for an unknown family.
int tagFamilySize(const std::string& family);

/// The layout of `family`'s bitmaps. Throws lightskin::Error for an unknown family.
TagLayout tagLayout(const std::string& family);

/// The tag `id` of `family` as CV_8UC1, one pixel per bit cell of the full tag INCLUDING its white
/// border cells: 255 = white, 0 = black; row 0 is the top of the printed tag. Upscale with
/// cv::INTER_NEAREST for printing or texturing. Throws lightskin::Error naming the family for an
/// unknown family or an id outside [0, tagFamilySize(family)).
cv::Mat renderTagBitmap(const std::string& family, int id);

} // namespace lightskin::tracking
