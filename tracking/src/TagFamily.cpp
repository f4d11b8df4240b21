#include "Families.h"

#include <lightskin/core/Error.h>
#include <lightskin/tracking/TagFamily.h>

#include <apriltag/tag16h5.h>
#include <apriltag/tag25h9.h>
#include <apriltag/tag36h10.h>
#include <apriltag/tag36h11.h>
#include <apriltag/tagCircle21h7.h>
#include <apriltag/tagCircle49h12.h>
#include <apriltag/tagCustom48h12.h>
#include <apriltag/tagStandard41h12.h>
#include <apriltag/tagStandard52h13.h>

#include <cstdint>

namespace lightskin::tracking {

namespace detail {
namespace {
struct FamilyEntry {
    const char* name;
    apriltag_family_t* (*create)();
    void (*destroy)(apriltag_family_t*);
};
// Debian's libapriltag 3.3.0 exports exactly these create/destroy pairs.
constexpr FamilyEntry familyTable[] = {
    {"tag36h11", &tag36h11_create, &tag36h11_destroy},
    {"tag36h10", &tag36h10_create, &tag36h10_destroy},
    {"tag25h9", &tag25h9_create, &tag25h9_destroy},
    {"tag16h5", &tag16h5_create, &tag16h5_destroy},
    {"tagCircle21h7", &tagCircle21h7_create, &tagCircle21h7_destroy},
    {"tagCircle49h12", &tagCircle49h12_create, &tagCircle49h12_destroy},
    {"tagCustom48h12", &tagCustom48h12_create, &tagCustom48h12_destroy},
    {"tagStandard41h12", &tagStandard41h12_create, &tagStandard41h12_destroy},
    {"tagStandard52h13", &tagStandard52h13_create, &tagStandard52h13_destroy},
};
} // namespace

FamilyPtr createFamily(const std::string& name) {
    for (const FamilyEntry& entry : familyTable) {
        if (name == entry.name) {
            FamilyPtr family(entry.create(), FamilyDeleter{entry.destroy});
            if (!family) throw Error(name, std::nullopt, "the AprilTag library could not create this family");
            return family;
        }
    }
    std::string known;
    for (const FamilyEntry& entry : familyTable) known += std::string(known.empty() ? "" : ", ") + entry.name;
    throw Error(name, std::nullopt, "unknown AprilTag family (supported: " + known + ")");
}

std::vector<std::string> familyNames() {
    std::vector<std::string> names;
    for (const FamilyEntry& entry : familyTable) names.emplace_back(entry.name);
    return names;
}
} // namespace detail

std::vector<std::string> supportedTagFamilies() { return detail::familyNames(); }

int tagFamilySize(const std::string& family) { return static_cast<int>(detail::createFamily(family)->ncodes); }

TagLayout tagLayout(const std::string& family) {
    const detail::FamilyPtr tagFamily = detail::createFamily(family);
    TagLayout layout;
    layout.totalCells = tagFamily->total_width;
    layout.blackBorderCells = tagFamily->width_at_border;
    layout.blackBorderStartCell = (tagFamily->total_width - tagFamily->width_at_border) / 2;
    return layout;
}

cv::Mat renderTagBitmap(const std::string& family, int id) {
    const detail::FamilyPtr tagFamily = detail::createFamily(family);
    if (id < 0 || static_cast<std::uint32_t>(id) >= tagFamily->ncodes) {
        throw Error(family, std::nullopt,
                    "tag id " + std::to_string(id) + " is outside the family (0.." +
                        std::to_string(tagFamily->ncodes - 1) + ")");
    }
    // The same drawing as the library's apriltag_to_image() (which lives in libapriltag-utils, not
    // worth a second library): a one-cell white ring just outside the border for normal families
    // (inside it for reversed-border ones), then every set bit of the code as a white cell at
    // (bit_x, bit_y) relative to the border square; everything else black.
    const apriltag_family_t& f = *tagFamily;
    cv::Mat bitmap(f.total_width, f.total_width, CV_8UC1, cv::Scalar(0));
    const int whiteRingWidth = f.width_at_border + (f.reversed_border ? 0 : 2);
    const int whiteRingStart = (f.total_width - whiteRingWidth) / 2;
    for (int i = 0; i < whiteRingWidth - 1; ++i) {
        bitmap.at<std::uint8_t>(whiteRingStart, whiteRingStart + i) = 255;
        bitmap.at<std::uint8_t>(whiteRingStart + i, whiteRingStart + whiteRingWidth - 1) = 255;
        bitmap.at<std::uint8_t>(whiteRingStart + whiteRingWidth - 1, whiteRingStart + i + 1) = 255;
        bitmap.at<std::uint8_t>(whiteRingStart + i + 1, whiteRingStart) = 255;
    }
    const int borderStart = (f.total_width - f.width_at_border) / 2;
    const std::uint64_t code = f.codes[id];
    for (std::uint32_t bit = 0; bit < f.nbits; ++bit) {
        if ((code >> (f.nbits - bit - 1u)) & 1u) {
            bitmap.at<std::uint8_t>(static_cast<int>(f.bit_y[bit]) + borderStart,
                                    static_cast<int>(f.bit_x[bit]) + borderStart) = 255;
        }
    }
    return bitmap;
}

} // namespace lightskin::tracking
