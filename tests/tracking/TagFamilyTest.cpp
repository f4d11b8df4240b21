// The tag bitmaps must be the library's real codes: a rendered, upscaled tag is decoded by the
// upstream detector (called directly here, independent of lightskin's detector) to the same id.
#include <lightskin/core/Error.h>
#include <lightskin/tracking/TagFamily.h>

#include <apriltag/apriltag.h>
#include <apriltag/tag25h9.h>
#include <apriltag/tag36h11.h>
#include <apriltag/tagStandard41h12.h>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cstring>

namespace lightskin::tracking {
namespace {

struct RawDetection {
    int id = -1;
    int hamming = -1;
    cv::Point2d corners[4];
};

// Upstream detector, straight C calls, on an 8-bit image.
std::vector<RawDetection> detectRaw(apriltag_family_t* (*create)(), void (*destroy)(apriltag_family_t*),
                                    const cv::Mat& grey) {
    apriltag_family_t* family = create();
    apriltag_detector_t* detector = apriltag_detector_create();
    apriltag_detector_add_family(detector, family);
    detector->quad_decimate = 1.0f;
    detector->nthreads = 1;
    image_u8_t image{grey.cols, grey.rows, static_cast<int32_t>(grey.step[0]), const_cast<uint8_t*>(grey.data)};
    zarray_t* found = apriltag_detector_detect(detector, &image);
    std::vector<RawDetection> result;
    for (int i = 0; i < zarray_size(found); ++i) {
        apriltag_detection_t* detection = nullptr;
        zarray_get(found, i, &detection);
        RawDetection raw;
        raw.id = detection->id;
        raw.hamming = detection->hamming;
        for (int k = 0; k < 4; ++k) raw.corners[k] = {detection->p[k][0], detection->p[k][1]};
        result.push_back(raw);
    }
    apriltag_detections_destroy(found);
    apriltag_detector_destroy(detector);
    destroy(family);
    return result;
}

// The bitmap upscaled by `pixelsPerCell` and padded with white.
cv::Mat upscaled(const cv::Mat& bitmap, int pixelsPerCell, int padding) {
    cv::Mat big;
    cv::resize(bitmap, big, {}, pixelsPerCell, pixelsPerCell, cv::INTER_NEAREST);
    cv::copyMakeBorder(big, big, padding, padding, padding, padding, cv::BORDER_CONSTANT, cv::Scalar(255));
    return big;
}

TEST(TagFamilyTest, Tag36h11LayoutIsTenCellsWithAnEightCellBlackBorder) {
    const TagLayout layout = tagLayout("tag36h11");
    EXPECT_EQ(layout.totalCells, 10);
    EXPECT_EQ(layout.blackBorderStartCell, 1);
    EXPECT_EQ(layout.blackBorderCells, 8);
    EXPECT_DOUBLE_EQ(layout.cellSizeMetres(0.16), 0.02);
    EXPECT_EQ(tagFamilySize("tag36h11"), 587);
}

TEST(TagFamilyTest, BitmapHasWhiteOuterRingAndBlackBorderRing) {
    const cv::Mat bitmap = renderTagBitmap("tag36h11", 0);
    ASSERT_EQ(bitmap.type(), CV_8UC1);
    ASSERT_EQ(bitmap.rows, 10);
    ASSERT_EQ(bitmap.cols, 10);
    for (int i = 0; i < 10; ++i) {
        EXPECT_EQ(bitmap.at<std::uint8_t>(0, i), 255);
        EXPECT_EQ(bitmap.at<std::uint8_t>(9, i), 255);
        EXPECT_EQ(bitmap.at<std::uint8_t>(i, 0), 255);
        EXPECT_EQ(bitmap.at<std::uint8_t>(i, 9), 255);
    }
    for (int i = 1; i < 9; ++i) {
        EXPECT_EQ(bitmap.at<std::uint8_t>(1, i), 0);
        EXPECT_EQ(bitmap.at<std::uint8_t>(8, i), 0);
        EXPECT_EQ(bitmap.at<std::uint8_t>(i, 1), 0);
        EXPECT_EQ(bitmap.at<std::uint8_t>(i, 8), 0);
    }
    // Only 0 and 255, and the data area is not uniform.
    int white = 0;
    for (int row = 2; row < 8; ++row) {
        for (int col = 2; col < 8; ++col) {
            const auto value = bitmap.at<std::uint8_t>(row, col);
            ASSERT_TRUE(value == 0 || value == 255);
            white += value == 255 ? 1 : 0;
        }
    }
    EXPECT_GT(white, 0);
    EXPECT_LT(white, 36);
    // Different ids give different bitmaps.
    EXPECT_GT(cv::norm(bitmap, renderTagBitmap("tag36h11", 1), cv::NORM_L1), 0.0);
}

TEST(TagFamilyTest, UpstreamDetectorDecodesRenderedTag36h11Ids) {
    for (const int id : {0, 1, 7, 42, 300, 586}) {
        const cv::Mat image = upscaled(renderTagBitmap("tag36h11", id), 12, 40);
        const auto detections = detectRaw(&tag36h11_create, &tag36h11_destroy, image);
        ASSERT_EQ(detections.size(), 1u) << "id " << id;
        EXPECT_EQ(detections[0].id, id);
        EXPECT_EQ(detections[0].hamming, 0);
        // The detected quad is the black-border square: cells 1..9 of 10 at 12 px per cell.
        // Corners are at pixel boundaries, i.e. at x = 40 + 12 - 0.5 in OpenCV's pixel-centre
        // convention; allow 1 px for the detector's edge fitting.
        const double low = 40 + 12 - 0.5;
        const double high = 40 + 12 * 9 - 0.5;
        // Counter-clockwise on screen from bottom-left: (low,high), (high,high), (high,low), (low,low).
        const cv::Point2d expected[4] = {{low, high}, {high, high}, {high, low}, {low, low}};
        for (int k = 0; k < 4; ++k) {
            EXPECT_NEAR(detections[0].corners[k].x, expected[k].x, 1.0) << "id " << id << " corner " << k;
            EXPECT_NEAR(detections[0].corners[k].y, expected[k].y, 1.0) << "id " << id << " corner " << k;
        }
    }
}

TEST(TagFamilyTest, OtherFamiliesDecodeToo) {
    {
        const auto detections =
            detectRaw(&tag25h9_create, &tag25h9_destroy, upscaled(renderTagBitmap("tag25h9", 17), 12, 40));
        ASSERT_EQ(detections.size(), 1u);
        EXPECT_EQ(detections[0].id, 17);
    }
    {
        const TagLayout layout = tagLayout("tagStandard41h12");
        EXPECT_EQ(layout.totalCells, 9);
        EXPECT_EQ(layout.blackBorderCells, 5);
        EXPECT_EQ(layout.blackBorderStartCell, 2);
        const auto detections = detectRaw(&tagStandard41h12_create, &tagStandard41h12_destroy,
                                          upscaled(renderTagBitmap("tagStandard41h12", 1234), 12, 40));
        ASSERT_EQ(detections.size(), 1u);
        EXPECT_EQ(detections[0].id, 1234);
    }
}

TEST(TagFamilyTest, UnknownFamilyAndIdThrowNamingTheFamily) {
    try {
        renderTagBitmap("tag99h99", 0);
        FAIL() << "no exception";
    } catch (const Error& error) {
        EXPECT_EQ(error.source(), "tag99h99");
    }
    EXPECT_THROW(renderTagBitmap("tag36h11", 587), Error);
    EXPECT_THROW(renderTagBitmap("tag36h11", -1), Error);
    EXPECT_THROW(tagLayout("nope"), Error);
}

} // namespace
} // namespace lightskin::tracking
