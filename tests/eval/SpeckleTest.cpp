// eval::measureSpeckle on constructed images whose speckle is known by construction.
#include <lightskin/core/Error.h>
#include <lightskin/eval/Speckle.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <limits>

namespace lightskin::test {
namespace {

constexpr int kSize = 64;

/// A smooth indirect image: a linear ramp in luminance from 0.2 to 1.0 across the image (grey,
/// so Y = the channel value), inside a disc of radius 28 px. Neighbours differ by 0.8/64 = 1.3 %
/// per pixel, so within 5x5 at most 2 px * 1.3 % / 0.2 = 12 % < 50 % of the median.
cv::Mat smoothRamp() {
    cv::Mat image(kSize, kSize, CV_32FC3);
    for (int v = 0; v < kSize; ++v)
        for (int u = 0; u < kSize; ++u)
            image.at<cv::Vec3f>(v, u) = cv::Vec3f::all(0.2f + 0.8f * float(u) / float(kSize));
    return image;
}

cv::Mat discCoverage() {
    cv::Mat mask(kSize, kSize, CV_8UC1, cv::Scalar(0));
    cv::circle(mask, {kSize / 2, kSize / 2}, 28, cv::Scalar(255), cv::FILLED);
    return mask;
}

std::size_t interiorCount(const cv::Mat& coverage) {
    cv::Mat interior;
    cv::erode(coverage, interior, cv::Mat::ones(5, 5, CV_8U), cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
    return std::size_t(cv::countNonZero(interior));
}

TEST(SpeckleTest, SmoothImageHasNone) {
    const cv::Mat coverage = discCoverage();
    const eval::SpeckleStats s = eval::measureSpeckle(smoothRamp(), coverage);
    EXPECT_EQ(s.interiorPixels, interiorCount(coverage)); // independent count of the eroded disc
    EXPECT_GT(s.interiorPixels, 2000u);                   // pi 26^2 = 2124
    EXPECT_EQ(s.specklePixels, 0u);
    EXPECT_EQ(s.speckleFraction(), 0.0);
    EXPECT_GT(s.meanLuminance, 0.2);
}

TEST(SpeckleTest, InjectedIsolatedOutliersAreCountedExactly) {
    cv::Mat image = smoothRamp();
    const cv::Mat coverage = discCoverage();
    // 16 outliers on a grid 6 px apart (no two within one 5x5 window, so every median stays the
    // ramp's): 8 black (0), 4 blown (x 20), 4 grey (x 1.8: speckle, neither black nor blown).
    int k = 0, black = 0, blown = 0;
    for (int v = 20; v <= 38; v += 6)
        for (int u = 20; u <= 38; u += 6, ++k) {
            cv::Vec3f& p = image.at<cv::Vec3f>(v, u);
            if (k < 8) {
                p = cv::Vec3f::all(0.0f);
                ++black;
            } else if (k < 12) {
                p *= 20.0f;
                ++blown;
            } else
                p *= 1.8f;
        }
    // A spike on the border band (not interior) must not count.
    image.at<cv::Vec3f>(kSize / 2, kSize / 2 + 27) = cv::Vec3f::all(100.0f);
    const eval::SpeckleStats s = eval::measureSpeckle(image, coverage);
    EXPECT_EQ(s.specklePixels, 16u);
    EXPECT_EQ(s.blackPixels, std::size_t(black));
    EXPECT_EQ(s.blownPixels, std::size_t(blown));
    EXPECT_DOUBLE_EQ(s.speckleFraction(), 16.0 / double(interiorCount(coverage)));
}

/// Paints a k x k square of the smooth ramp at (u0, v0) (top left) with `factor` times the ramp.
void paintBlotch(cv::Mat& image, int u0, int v0, int k, float factor) {
    for (int v = v0; v < v0 + k; ++v)
        for (int u = u0; u < u0 + k; ++u) image.at<cv::Vec3f>(v, u) *= factor;
}

TEST(SpeckleTest, InjectedBlotchesAndStreaksAreCountedWhole) {
    // On the smooth ramp (background b): 2x2 and 3x3 blotches, bright (4 b) and black (0), and a 1 px
    // wide black streak 5 px long, each > 6 px from the others so every 5x5 window holds at most one.
    // Every pixel of them is speckle by the definition (Speckle.h): the median of its window is the
    // background (at most 9 of 25 pixels differ), and no direction explains it: along each of the four
    // directions a +-1 or +-2 pair holds background on at least one side, so the line through it
    // predicts >= (4 b + b) / 2 = 2.5 b against 4 b, or <= b / 2 against 0 (both > 50 % off; a
    // bright blotch needs > 3 b for the mixed pair); across the streak both neighbours are b.
    cv::Mat image = smoothRamp();
    paintBlotch(image, 18, 18, 2, 4.0f);
    paintBlotch(image, 26, 18, 2, 0.0f);
    paintBlotch(image, 36, 18, 3, 4.0f);
    paintBlotch(image, 18, 28, 3, 0.0f);
    for (int u = 28; u < 33; ++u) image.at<cv::Vec3f>(30, u) = cv::Vec3f::all(0.0f);
    const eval::SpeckleStats s = eval::measureSpeckle(image, discCoverage());
    EXPECT_EQ(s.specklePixels, 4u + 4u + 9u + 9u + 5u);
    EXPECT_EQ(s.blackPixels, 4u + 9u + 5u);
    EXPECT_EQ(s.blownPixels, 0u);
}

TEST(SpeckleTest, SteepSmoothFalloffsAreNotSpeckle) {
    // Smooth images whose 5x5 median is far from the centre pixel: a lit disc of radius 14 px whose
    // edge falls from 1 to ~0 within ~4 px (logistic, 1 px scale: neighbours across the edge differ
    // by up to 2.7x), and steep linear ramps (0 -> 6.4 across 64 px, i.e. 0.1 per px, from 0.05)
    // in four orientations. Along its contour (a straight line at 2 px scale) every pixel lies on
    // the line through its neighbours, and across it between them, so nothing is speckle.
    cv::Mat image(kSize, kSize, CV_32FC3);
    for (int v = 0; v < kSize; ++v)
        for (int u = 0; u < kSize; ++u) {
            const double r = std::hypot(u - 32.0, v - 32.0);
            image.at<cv::Vec3f>(v, u) = cv::Vec3f::all(float(1.0 / (1.0 + std::exp(r - 14.0))));
        }
    const cv::Mat all(kSize, kSize, CV_8UC1, cv::Scalar(1));
    const eval::SpeckleStats disc = eval::measureSpeckle(image, all);
    EXPECT_EQ(disc.specklePixels, 0u) << disc.describe();
    EXPECT_GT(disc.meanLuminance, 0.1); // lit: ~pi 14^2 / 60^2 of the interior
    for (const auto& [du, dv] : {std::pair{1, 0}, {0, 1}, {1, 1}, {1, -1}}) {
        for (int v = 0; v < kSize; ++v)
            for (int u = 0; u < kSize; ++u)
                image.at<cv::Vec3f>(v, u) = cv::Vec3f::all(0.05f + 0.1f * float(du * u + dv * v + kSize));
        const eval::SpeckleStats ramp = eval::measureSpeckle(image, all);
        EXPECT_EQ(ramp.specklePixels, 0u) << du << "," << dv << ": " << ramp.describe();
    }
    // The lit quadrant of two such edges (smooth, a curved contour at its corner): the median alone
    // flags its corner (2 pixels: the case that tells the two definitions apart); along a diagonal
    // every pixel there still lies on the lines through its neighbours, so the refined measure
    // flags none.
    for (int v = 0; v < kSize; ++v)
        for (int u = 0; u < kSize; ++u)
            image.at<cv::Vec3f>(v, u) =
                cv::Vec3f::all(float(1.0 / ((1.0 + std::exp(32.0 - u)) * (1.0 + std::exp(32.0 - v)))));
    EXPECT_GT(eval::measureSpeckle(image, all, nullptr, cv::Mat(), false).specklePixels, 0u);
    EXPECT_EQ(eval::measureSpeckle(image, all).specklePixels, 0u);
    // The same disc with one pixel of its edge zeroed and one doubled is found (2 pixels).
    for (int v = 0; v < kSize; ++v)
        for (int u = 0; u < kSize; ++u)
            image.at<cv::Vec3f>(v, u) =
                cv::Vec3f::all(float(1.0 / (1.0 + std::exp(std::hypot(u - 32.0, v - 32.0) - 14.0))));
    image.at<cv::Vec3f>(32, 32 + 13) = cv::Vec3f::all(0.0f); // on the edge: 0.73 -> 0
    image.at<cv::Vec3f>(32 - 12, 32) *= 2.0f;                // inside the edge: 0.88 -> 1.76
    EXPECT_EQ(eval::measureSpeckle(image, all).specklePixels, 2u);
}

TEST(SpeckleTest, ThresholdIsFiftyPercentOfTheMedian) {
    // Uniform 1.0; one pixel at 1.45 (45 % off: not speckle), one at 1.55 and one at 0.45 (55 %: speckle).
    cv::Mat image(kSize, kSize, CV_32FC3, cv::Scalar::all(1.0));
    image.at<cv::Vec3f>(20, 20) = cv::Vec3f::all(1.45f);
    image.at<cv::Vec3f>(30, 30) = cv::Vec3f::all(1.55f);
    image.at<cv::Vec3f>(40, 40) = cv::Vec3f::all(0.45f);
    const eval::SpeckleStats s = eval::measureSpeckle(image, cv::Mat(kSize, kSize, CV_8UC1, cv::Scalar(1)));
    EXPECT_EQ(s.interiorPixels, std::size_t((kSize - 4) * (kSize - 4)));
    EXPECT_EQ(s.specklePixels, 2u);
    EXPECT_EQ(s.blackPixels, 0u);
    EXPECT_EQ(s.blownPixels, 0u);
}

TEST(SpeckleTest, DenseNoiseIsMostlySpeckle) {
    // Half the pixels 0, half 1 at random: the median is 0 or 1 and about half the pixels differ
    // from it by 100 %; a measure that missed dense blotches would report ~0.
    cv::Mat noise(kSize, kSize, CV_32FC1), image;
    cv::RNG rng(12);
    rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
    cv::threshold(noise, noise, 0.5, 1.0, cv::THRESH_BINARY);
    cv::merge(std::vector<cv::Mat>{noise, noise, noise}, image);
    const eval::SpeckleStats s = eval::measureSpeckle(image, cv::Mat(kSize, kSize, CV_8UC1, cv::Scalar(1)));
    EXPECT_GT(s.speckleFraction(), 0.3);
    EXPECT_LT(s.speckleFraction(), 0.7);
}

TEST(SpeckleTest, DarkRegionsBelowTheFloorDoNotCount) {
    // Left half lit (1.0), right half in shadow at 1e-4 with one pixel at 5e-4 and one at 0.02 (5x
    // and 200x their median, but within 0.5 x the floor 0.1 x mean 0.5 = 0.025 of it): not speckle;
    // 0.03 would be. The shadow edge itself moves the median by whole
    // steps only, so it adds nothing either.
    cv::Mat image(kSize, kSize, CV_32FC3, cv::Scalar::all(1.0));
    image(cv::Rect(kSize / 2, 0, kSize / 2, kSize)).setTo(cv::Scalar::all(1e-4));
    image.at<cv::Vec3f>(30, 50) = cv::Vec3f::all(5e-4f);
    image.at<cv::Vec3f>(40, 50) = cv::Vec3f::all(0.02f);
    const eval::SpeckleStats s = eval::measureSpeckle(image, cv::Mat(kSize, kSize, CV_8UC1, cv::Scalar(1)));
    EXPECT_EQ(s.specklePixels, 0u);
}

TEST(SpeckleTest, NonFiniteIsBlownAndBadInputThrows) {
    cv::Mat image(kSize, kSize, CV_32FC3, cv::Scalar::all(1.0));
    image.at<cv::Vec3f>(30, 30)[1] = std::numeric_limits<float>::quiet_NaN();
    image.at<cv::Vec3f>(40, 40)[0] = std::numeric_limits<float>::infinity();
    const eval::SpeckleStats s = eval::measureSpeckle(image, cv::Mat(kSize, kSize, CV_8UC1, cv::Scalar(1)));
    EXPECT_EQ(s.specklePixels, 2u);
    EXPECT_EQ(s.blownPixels, 2u);
    EXPECT_DOUBLE_EQ(s.meanLuminance, 1.0);
    EXPECT_THROW(eval::measureSpeckle(cv::Mat(4, 4, CV_32FC1), cv::Mat(4, 4, CV_8UC1)), Error);
    EXPECT_THROW(eval::measureSpeckle(cv::Mat(4, 4, CV_32FC3), cv::Mat(5, 4, CV_8UC1)), Error);
}

TEST(SpeckleTest, BackFacesLeaveTheInteriorAndEveryBlackFrontPixelCounts) {
    // Uniform light 1.0 on the front faces; a 4 x 4 hole at (30..33, 30..33) shows a back face, dark (0, as
    // the GI techniques write there). Without the mask the hole's corner pixels count as black (9 of
    // their window's 25 samples are 0, the median is 1.0); with it the hole leaves the interior.
    cv::Mat image(kSize, kSize, CV_32FC3, cv::Scalar::all(1.0));
    const cv::Mat all(kSize, kSize, CV_8UC1, cv::Scalar(255));
    cv::Mat back(kSize, kSize, CV_8UC1, cv::Scalar(0));
    const cv::Rect hole(30, 30, 4, 4);
    image(hole).setTo(cv::Scalar::all(0.0));
    back(hole).setTo(cv::Scalar(255));
    EXPECT_GE(eval::measureSpeckle(image, all).blackPixels, 4u);
    cv::Mat map;
    const eval::SpeckleStats masked = eval::measureSpeckle(image, all, &map, cv::Mat(), true, back);
    EXPECT_EQ(masked.specklePixels, 0u);
    EXPECT_EQ(masked.interiorPixels, std::size_t((kSize - 4) * (kSize - 4) - 16)); // covered: still eroded as before
    EXPECT_EQ(cv::countNonZero(map(hole)), 0);                                     // not measured
    EXPECT_DOUBLE_EQ(masked.meanLuminance, 1.0);

    // A black front-face pixel in a notch of a hole: the back face covers columns 30-32 of rows 30-34 but
    // (32, 32), which is front facing and black. Its window (columns 30-34) holds 14 back-face zeros, the
    // pixel's own 0 and 10 lit front samples: the plain median is 0 (an "unlit" neighbourhood, so the
    // pixel is not black by the definition), the median of the 11 front samples is 1.0.
    image.setTo(cv::Scalar::all(1.0));
    back.setTo(cv::Scalar(0));
    const cv::Rect notched(30, 30, 3, 5);
    image(notched).setTo(cv::Scalar::all(0.0));
    back(notched).setTo(cv::Scalar(255));
    back.at<std::uint8_t>(32, 32) = 0; // (row, column)
    cv::Mat plainMap;
    eval::measureSpeckle(image, all, &plainMap);
    EXPECT_NE(plainMap.at<std::uint8_t>(32, 32), 255); // the plain measure misses it
    const eval::SpeckleStats front = eval::measureSpeckle(image, all, &map, cv::Mat(), true, back);
    EXPECT_EQ(front.blackPixels, 1u);
    EXPECT_EQ(front.specklePixels, 1u);
    EXPECT_EQ(map.at<std::uint8_t>(32, 32), 255);
    EXPECT_THROW(eval::measureSpeckle(image, all, nullptr, cv::Mat(), true, cv::Mat(4, 4, CV_8UC1)), Error);
}

TEST(SpeckleTest, SmoothSurfaceMaskDropsCreasesAndDepthSteps) {
    // Left half faces +z, right half is turned by 40 degrees (a crease at u = 32); a depth step of
    // 10 % along v = 32. Pixels whose 5x5 window crosses either are not smooth; the others are.
    cv::Mat coverage(kSize, kSize, CV_8UC1, cv::Scalar(255)), normals(kSize, kSize, CV_32FC3),
        depth(kSize, kSize, CV_32FC1);
    const float a = float(40.0 * 3.14159265358979 / 180.0);
    for (int v = 0; v < kSize; ++v)
        for (int u = 0; u < kSize; ++u) {
            normals.at<cv::Vec3f>(v, u) = u < 32 ? cv::Vec3f(0, 0, 1) : cv::Vec3f(std::sin(a), 0, std::cos(a));
            depth.at<float>(v, u) = v < 32 ? 1.0f : 1.1f;
        }
    cv::Mat mask;
    eval::smoothSurfaceMaskInto(coverage, normals, depth, 30.0, 0.02, mask);
    EXPECT_EQ(mask.at<std::uint8_t>(10, 10), 255);
    EXPECT_EQ(mask.at<std::uint8_t>(10, 29), 255); // window u = 27..31: one side of the crease
    EXPECT_EQ(mask.at<std::uint8_t>(10, 30), 0);   // window reaches u = 32
    EXPECT_EQ(mask.at<std::uint8_t>(29, 10), 255);
    EXPECT_EQ(mask.at<std::uint8_t>(30, 10), 0); // window reaches the depth step
    EXPECT_EQ(mask.at<std::uint8_t>(1, 10), 0);  // image border: no full window
    // With a 45-degree tolerance the crease is smooth.
    eval::smoothSurfaceMaskInto(coverage, normals, depth, 45.0, 0.02, mask);
    EXPECT_EQ(mask.at<std::uint8_t>(10, 30), 255);
    // measureSpeckle restricted to the mask: an outlier outside it is not counted.
    cv::Mat image(kSize, kSize, CV_32FC3, cv::Scalar::all(1.0));
    image.at<cv::Vec3f>(30, 10) = cv::Vec3f::all(0.0f);
    image.at<cv::Vec3f>(10, 10) = cv::Vec3f::all(0.0f);
    eval::smoothSurfaceMaskInto(coverage, normals, depth, 30.0, 0.02, mask);
    EXPECT_EQ(eval::measureSpeckle(image, coverage, nullptr, mask).specklePixels, 1u);
    EXPECT_EQ(eval::measureSpeckle(image, coverage).specklePixels, 2u);
}

/// Normals turning about the y axis: 0 for u < 32, then by `degreesPerPixel` per column (a kink of the
/// normal field at u = 32, as where two triangles' vertex normals meet); `linear`: the turn runs over
/// the whole image (0 at u = 32), no kink. Depth 1 m everywhere, all covered.
void turningSurface(double degreesPerPixel, bool linear, cv::Mat& coverage, cv::Mat& normals, cv::Mat& depth) {
    coverage = cv::Mat(kSize, kSize, CV_8UC1, cv::Scalar(255));
    normals.create(kSize, kSize, CV_32FC3);
    depth = cv::Mat(kSize, kSize, CV_32FC1, cv::Scalar(1.0));
    for (int v = 0; v < kSize; ++v)
        for (int u = 0; u < kSize; ++u) {
            const int steps = linear ? u - 32 : std::max(0, u - 32);
            const double a = double(steps) * degreesPerPixel * 3.14159265358979323846 / 180.0;
            normals.at<cv::Vec3f>(v, u) = cv::Vec3f(float(std::sin(a)), 0.0f, float(std::cos(a)));
        }
}

TEST(SpeckleTest, NormalSensitivityLeavesOutKinksOfTheNormalFieldUnderGrazingLight) {
    // The kink at u = 32, 2 degrees per pixel beyond it: the window centred on u = 32 holds normals at
    // 0, 0, 0, 2, 4 degrees per row, whose mean lies at atan2(sin 2 + sin 4, 3 + cos 2 + cos 4) = 1.2000
    // degrees (0.020944 rad) from the centre's. So it is left out for S > 0.5 / 0.020944 = 23.87 and
    // kept below; windows on the flat side (u <= 30) have Delta = 0 and are kept for any S. Centred on
    // u = 33: normals 0, 0, 2, 4, 6 -> mean 2.4 degrees, centre 2: Delta = 0.4 degrees, kept below 71.6.
    cv::Mat coverage, normals, depth, plain, mask;
    turningSurface(2.0, false, coverage, normals, depth);
    eval::smoothSurfaceMaskInto(coverage, normals, depth, 30.0, 0.02, plain);
    ASSERT_EQ(cv::countNonZero(plain), (kSize - 4) * (kSize - 4)); // spreads of <= 8 < 30 degrees
    const auto withS = [&](float s) {
        eval::smoothSurfaceMaskInto(coverage, normals, depth, 30.0, 0.02, mask,
                                    cv::Mat(kSize, kSize, CV_32FC1, cv::Scalar(s)));
    };
    withS(0.0f); // S = 0: the plain mask
    EXPECT_EQ(cv::countNonZero(mask), cv::countNonZero(plain));
    withS(23.0f);
    EXPECT_EQ(mask.at<std::uint8_t>(10, 32), 255);
    withS(25.0f);
    EXPECT_EQ(mask.at<std::uint8_t>(10, 32), 0);
    EXPECT_EQ(mask.at<std::uint8_t>(10, 29), 255); // flat window, Delta = 0
    EXPECT_EQ(mask.at<std::uint8_t>(10, 33), 255); // Delta = 0.4 degrees: S Delta = 0.17
    withS(80.0f);
    EXPECT_EQ(mask.at<std::uint8_t>(10, 33), 0); // S Delta = 0.56
    EXPECT_EQ(mask.at<std::uint8_t>(10, 29), 255);
    withS(std::numeric_limits<float>::infinity());
    EXPECT_EQ(mask.at<std::uint8_t>(10, 29), 255); // all normals equal
    EXPECT_EQ(mask.at<std::uint8_t>(10, 30), 255); // window u = 28..32: still flat
    EXPECT_EQ(mask.at<std::uint8_t>(10, 31), 0);   // the window reaches the turn (u = 33)
    withS(std::numeric_limits<float>::quiet_NaN());
    EXPECT_EQ(cv::countNonZero(mask), 0);
    // A normal field that turns linearly (no kink): every centre normal is its window's mean, so a
    // steep S leaves it in (to first order its light is linear, which the smooth-profile test takes).
    turningSurface(2.0, true, coverage, normals, depth);
    withS(1000.0f);
    EXPECT_EQ(cv::countNonZero(mask), (kSize - 4) * (kSize - 4));
    EXPECT_THROW(eval::smoothSurfaceMaskInto(coverage, normals, depth, 30.0, 0.02, mask, cv::Mat(4, 4, CV_32FC1)),
                 Error);
    EXPECT_THROW(eval::smoothSurfaceMaskInto(coverage, normals, depth, 30.0, 0.02, mask,
                                             cv::Mat(kSize, kSize, CV_64FC1, cv::Scalar(1.0))),
                 Error);
}

TEST(SpeckleTest, DefectsOnAFlatPatchAreCountedWhateverTheNormalSensitivity) {
    // Equal normals everywhere: the light's sensitivity to the normal cannot explain anything, so the
    // mask keeps every full window even at S = +inf, and the outliers, the streak and the 2x2 blotch
    // of the tests above are counted pixel for pixel as without the mask.
    cv::Mat coverage, normals, depth, mask;
    turningSurface(0.0, false, coverage, normals, depth);
    eval::smoothSurfaceMaskInto(coverage, normals, depth, 30.0, 0.02, mask,
                                cv::Mat(kSize, kSize, CV_32FC1, cv::Scalar(std::numeric_limits<float>::infinity())));
    ASSERT_EQ(cv::countNonZero(mask), (kSize - 4) * (kSize - 4));
    cv::Mat image = smoothRamp();
    image.at<cv::Vec3f>(10, 10) = cv::Vec3f::all(0.0f); // black outlier
    image.at<cv::Vec3f>(10, 50) *= 20.0f;               // blown outlier
    paintBlotch(image, 18, 18, 2, 4.0f);
    paintBlotch(image, 36, 18, 3, 4.0f);
    paintBlotch(image, 18, 36, 3, 0.0f);
    for (int u = 28; u < 33; ++u) image.at<cv::Vec3f>(50, u) = cv::Vec3f::all(0.0f); // 1 px black streak
    const eval::SpeckleStats withMask = eval::measureSpeckle(image, coverage, nullptr, mask);
    const eval::SpeckleStats without = eval::measureSpeckle(image, coverage);
    EXPECT_EQ(withMask.specklePixels, 1u + 1u + 4u + 9u + 9u + 5u);
    EXPECT_EQ(withMask.blackPixels, 1u + 9u + 5u);
    EXPECT_EQ(withMask.blownPixels, 1u);
    EXPECT_EQ(withMask.specklePixels, without.specklePixels);
    EXPECT_EQ(withMask.interiorPixels, without.interiorPixels);
}

TEST(SpeckleTest, HiddenPixelsLeaveTheCountAndEveryVisibleBlackPixelStays) {
    // The composite hides the disc's rows >= 40 behind real depth (a contact line; Speckle.h, "What the user
    // sees"). Isolated black pixels 6 px apart (one per 5x5 window, so every median stays the ramp's) in the
    // hidden rows 41 and 44 and in the visible rows right above the line, 39 and 38, and in the middle (30).
    cv::Mat image = smoothRamp();
    const cv::Mat coverage = discCoverage();
    cv::Mat visible = coverage.clone();
    visible.rowRange(40, kSize).setTo(cv::Scalar(0));
    std::size_t shownBlack = 0, hiddenBlack = 0;
    for (const int v : {30, 38, 39, 41, 44})
        for (int u = 14 + (v % 2) * 3; u <= 48; u += 6) {
            image.at<cv::Vec3f>(v, u) = cv::Vec3f::all(0.0f);
            (v < 40 ? shownBlack : hiddenBlack) += 1;
        }
    ASSERT_GT(hiddenBlack, 0u);
    const eval::SpeckleStats all = eval::measureSpeckle(image, coverage);
    const eval::SpeckleStats shown = eval::measureSpeckle(image, coverage, nullptr, visible);
    EXPECT_EQ(all.blackPixels, shownBlack + hiddenBlack); // without the mask the hidden ones counted too
    EXPECT_EQ(shown.blackPixels, shownBlack);             // every visible one, those next to the line included
    EXPECT_EQ(shown.specklePixels, shownBlack);
    cv::Mat interior, shownInterior;
    cv::erode(coverage, interior, cv::Mat::ones(5, 5, CV_8U), cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
    cv::bitwise_and(interior, visible, shownInterior);
    EXPECT_EQ(shown.interiorPixels, std::size_t(cv::countNonZero(shownInterior)));
    // Why the mask restricts the counted pixels and is not passed as the coverage: eroded, it would drop rows
    // 38-39 and with them visible black pixels.
    const eval::SpeckleStats eroded = eval::measureSpeckle(image, visible);
    EXPECT_LT(eroded.blackPixels, shownBlack);
}

} // namespace
} // namespace lightskin::test
