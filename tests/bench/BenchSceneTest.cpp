// The synthetic scenes of the benchmarks (bench/include/lightskin/bench/BenchScene.h), against closed
// forms: the analytic room's depth lands on the room's planes or the real box, the UV sphere's area
// and size, the VAL map's areas, and the option parsing the bench commands share.
#include "ExpectError.h"

#include <lightskin/bench/BenchScene.h>
#include <lightskin/bench/OptionLists.h>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

namespace {

// The room and the box of BenchScene.h (metres, world frame, Z up), restated from its documentation.
constexpr double kRoomLo[3] = {-1.6, -1.0, 0.0}, kRoomHi[3] = {1.6, 2.2, 2.4};
constexpr double kBoxLo[3] = {0.65, 0.95, 0.0}, kBoxHi[3] = {1.15, 1.45, 0.6};

bool within(double x, double lo, double hi, double tol) { return x >= lo - tol && x <= hi + tol; }

} // namespace

TEST(BenchScene, RoomDepthLandsOnTheRoomsPlanesOrTheBox) {
    const lightskin::CameraIntrinsics K = lightskin::bench::depthIntrinsics();
    const lightskin::Pose pose = lightskin::bench::depthCameraPose();
    cv::Mat depth, colour;
    lightskin::bench::renderRoom(K, pose, 0.0, depth, colour);
    ASSERT_EQ(depth.cols, 640);
    ASSERT_EQ(depth.rows, 480);
    const glm::dmat4 m = pose.matrix();
    const glm::dvec3 origin(m[3]);
    const glm::dmat3 rotation(m);
    // Depth is stored as float: at most ~5 m here, so rounding is < 5 m x 2^-24 = 3e-7 m, times at most
    // 1.3 for the ray's length off the axis; 1e-5 m leaves room for the double-precision back-projection.
    const double tol = 1e-5;
    int onBox = 0, onRoom = 0, nowhere = 0;
    for (int v = 0; v < depth.rows; ++v)
        for (int u = 0; u < depth.cols; ++u) {
            const double d = depth.at<float>(v, u);
            const glm::dvec3 p = origin + rotation * glm::dvec3((u - K.cx) / K.fx * d, (v - K.cy) / K.fy * d, d);
            bool inRoom = true, onRoomPlane = false, inBox = true, onBoxFace = false;
            for (int a = 0; a < 3; ++a) {
                inRoom = inRoom && within(p[a], kRoomLo[a], kRoomHi[a], tol);
                onRoomPlane = onRoomPlane || std::abs(p[a] - kRoomLo[a]) < tol || std::abs(p[a] - kRoomHi[a]) < tol;
                inBox = inBox && within(p[a], kBoxLo[a], kBoxHi[a], tol);
                onBoxFace = onBoxFace || std::abs(p[a] - kBoxLo[a]) < tol || std::abs(p[a] - kBoxHi[a]) < tol;
            }
            if (inBox && onBoxFace && p.z > tol) {
                ++onBox;
                // The box's colour, sRGB (0.65, 0.35, 0.30) as BGR 255 x = (165.75, 89.25, 76.5); renderRoom
                // rounds 255 x + 0.5, so within one code value.
                const cv::Vec3b c = colour.at<cv::Vec3b>(v, u);
                EXPECT_TRUE(std::abs(c[0] - 165.75) <= 1.0 && std::abs(c[1] - 89.25) <= 1.0 &&
                            std::abs(c[2] - 76.5) <= 1.0)
                    << u << "," << v;
            } else if (inRoom && onRoomPlane) {
                ++onRoom;
            } else {
                ++nowhere;
            }
        }
    EXPECT_EQ(nowhere, 0);
    // The camera looks at the box from 2 m: it covers a visible patch of the image (a few percent), and
    // the room the rest.
    EXPECT_GT(onBox, 1000);
    EXPECT_GT(onRoom, 640 * 480 / 2);
}

TEST(BenchScene, UvSphereHasTheRequestedSizeRadiusAndArea) {
    const float r = 0.4f;
    const lightskin::TriangleMesh sphere = lightskin::bench::uvSphere(r, 20000);
    const std::size_t triangles = sphere.indices.size() / 3;
    // stacks = round(sqrt(T / 4)) rounds the request by at most one stack: 2 x 0.5 / 71 = 1.4 % here.
    EXPECT_NEAR(double(triangles), 20000.0, 0.015 * 20000.0);
    for (const auto& p : sphere.positions) ASSERT_NEAR(glm::length(p), r, 1e-6);
    double area = 0.0;
    for (std::size_t i = 0; i < sphere.indices.size(); i += 3) {
        const glm::dvec3 a(sphere.positions[sphere.indices[i]]), b(sphere.positions[sphere.indices[i + 1]]),
            c(sphere.positions[sphere.indices[i + 2]]);
        area += 0.5 * glm::length(glm::cross(b - a, c - a));
    }
    // An inscribed polyhedron: less than 4 pi r^2, short by O(step^2) with step = pi / 71 = 0.044 rad;
    // the flat quads lose about step^2 / 6 = 3e-4 of the area, so within 0.1 %.
    const double exact = 4.0 * std::numbers::pi * double(r) * double(r);
    EXPECT_LT(area, exact);
    EXPECT_GT(area, 0.999 * exact);
}

TEST(BenchScene, ValMapCoversTheWallAndTheCeiling) {
    const auto vals = lightskin::bench::valMap(40, 30);
    ASSERT_EQ(vals.size(), 1200u);
    double wall = 0.0, ceiling = 0.0;
    for (const auto& l : vals) (l.normal.z < 0.0f ? ceiling : wall) += double(l.area);
    // Wall: 2.4 m x 1.6 m; ceiling: 2.4 m x 2.4 m; float areas summed 600 times each: 1e-4 m^2 is generous.
    EXPECT_NEAR(wall, 2.4 * 1.6, 1e-4);
    EXPECT_NEAR(ceiling, 2.4 * 2.4, 1e-4);
}

TEST(BenchOptions, ListsAndValMapSizesParseOrNameTheOption) {
    const auto ints = lightskin::bench::splitList<int>("64,,256,", [](const std::string& s) { return std::stoi(s); });
    EXPECT_EQ(ints, (std::vector<int>{64, 256}));
    EXPECT_TRUE(lightskin::bench::splitList<int>("", [](const std::string& s) { return std::stoi(s); }).empty());
    EXPECT_EQ(lightskin::bench::parseValMapSize("160x120"), std::make_pair(160, 120));
    for (const char* bad : {"160", "0x120", "160x1", "x"})
        lightskin::test::expectError([&] { lightskin::bench::parseValMapSize(bad); },
                                     {"--vals", std::nullopt, "expected WIDTHxHEIGHT"});
}
