#include <lightskin/core/Error.h>
#include <lightskin/core/RgbdFrame.h>

#include <gtest/gtest.h>

namespace lightskin::test {
namespace {

RgbdFrame makeFrame() {
    RgbdFrame frame;
    frame.index = 7;
    frame.colour = cv::Mat(4, 6, CV_8UC3, cv::Scalar(1, 2, 3));
    frame.depth = cv::Mat(4, 6, CV_16UC1, cv::Scalar(5000));
    frame.depthScaleMetres = 0.0002;
    frame.colourIntrinsics = frame.depthIntrinsics = CameraIntrinsics{6, 4, 5, 5, 2.5, 1.5, {}};
    return frame;
}

TEST(RgbdFrameTest, DepthInMetresUsesTheScale) {
    const RgbdFrame frame = makeFrame();
    EXPECT_DOUBLE_EQ(frame.depthMetresAt(2, 1), 1.0);
}

TEST(RgbdFrameTest, CloneIsDeep) {
    const RgbdFrame frame = makeFrame();
    RgbdFrame copy = frame.clone();
    copy.depth.at<std::uint16_t>(0, 0) = 0;
    EXPECT_EQ(frame.depth.at<std::uint16_t>(0, 0), 5000);
}

TEST(RgbdFrameTest, ValidateNamesSourceFrameAndCause) {
    RgbdFrame frame = makeFrame();
    EXPECT_NO_THROW(frame.validate("test.rec"));
    frame.depth = cv::Mat(4, 6, CV_32FC1, cv::Scalar(1.0));
    try {
        frame.validate("test.rec");
        FAIL();
    } catch (const Error& error) {
        EXPECT_EQ(error.source(), "test.rec");
        EXPECT_EQ(error.frame(), 7);
        EXPECT_NE(error.cause().find("16-bit"), std::string::npos);
    }
    frame = makeFrame();
    frame.depth = cv::Mat(3, 6, CV_16UC1, cv::Scalar(0));
    EXPECT_THROW(frame.validate("x"), Error);
    frame = makeFrame();
    frame.depthScaleMetres = 0.0;
    EXPECT_THROW(frame.validate("x"), Error);
}

} // namespace
} // namespace lightskin::test
