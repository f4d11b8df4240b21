// Guard G11: sparse points under the real surface, and their weight 0 in eq. 12-13.
// Flags: a synthetic depth image (a plane at 1 m with a hole, a NaN and a step) and points placed
// by construction above it, on it, inside and beyond the noise tolerance, outside the image, behind
// the camera and on the holes. The tolerance is written here from the published noise model (Nguyen,
// Izadi, Lovell 2012), 3 sigma as the VAL occupancy cull, not taken from the
// code. Interpolation: eq. 12-13's weights by hand.
#include <lightskin/gi/lightskin/BuriedSparsePoints.h>
#include <lightskin/gi/reference/LightSkinReference.h>

#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

using namespace lightskin;
using glm::dvec3;
namespace ref = gi::reference;

namespace {

constexpr int kWidth = 40, kHeight = 30;
constexpr double kFocal = 50.0, kCx = 19.5, kCy = 14.5;
constexpr double kPlane = 1.0; // metres along the optical axis

// 3 sigma of the Kinect v1 axial noise at the plane's depth: 3 (0.0012 + 0.0019 (1.0 - 0.4)^2) m.
constexpr double kTolerance = 3.0 * (0.0012 + 0.0019 * 0.36); // 0.005652 m

struct DepthImage {
    std::vector<float> depth = std::vector<float>(std::size_t(kWidth) * std::size_t(kHeight), float(kPlane));
    gi::RealDepthView view(double fy = kFocal) const {
        gi::RealDepthView v;
        v.data = depth.data();
        v.width = kWidth;
        v.height = kHeight;
        v.intrinsics = glm::vec4(float(kFocal), float(fy), float(kCx), float(kCy));
        return v;
    }
    float& at(int u, int v) { return depth[std::size_t(v) * std::size_t(kWidth) + std::size_t(u)]; }
};

/// The camera-frame point seen through pixel (u, v) at depth z (identity camera_T_world).
dvec3 throughPixel(double u, double v, double z, double fy = kFocal) {
    return {(u - kCx) * z / kFocal, (v - kCy) * z / fy, z};
}

} // namespace

TEST(BuriedSparsePoints, FlagsFollowTheDepthPlaneAndItsNoiseTolerance) {
    DepthImage image;
    image.at(10, 10) = 0.0f;                                    // a hole
    image.at(12, 10) = std::numeric_limits<float>::quiet_NaN(); // a missing value
    image.at(8, 5) = 0.0f;                                      // the rounding probe's neighbour
    const gi::RealDepthView view = image.view();
    const auto buried = [&](const dvec3& p) { return gi::isBuriedUnderRealSurface(p, view); };

    EXPECT_FALSE(buried(throughPixel(5, 5, 0.9))) << "10 cm in front of the surface";
    EXPECT_FALSE(buried(throughPixel(5, 5, kPlane))) << "on the surface";
    EXPECT_FALSE(buried(throughPixel(5, 5, kPlane + 0.99 * kTolerance))) << "within the noise";
    EXPECT_TRUE(buried(throughPixel(5, 5, kPlane + 1.01 * kTolerance))) << "just beyond the noise";
    EXPECT_TRUE(buried(throughPixel(5, 5, kPlane + 0.2))) << "20 cm under the surface";
    // Nearest pixel centre (centres at integers): u = 7.4 reads pixel 7 (1 m), u = 7.6 pixel 8 (a hole).
    EXPECT_TRUE(buried(throughPixel(7.4, 5, 1.2)));
    EXPECT_FALSE(buried(throughPixel(7.6, 5, 1.2)));
    // Holes and missing values are not buried, nor are points outside the image or behind the camera.
    EXPECT_FALSE(buried(throughPixel(10, 10, 1.2))) << "on a hole (0)";
    EXPECT_FALSE(buried(throughPixel(12, 10, 1.2))) << "on a NaN";
    EXPECT_TRUE(buried(throughPixel(11, 10, 1.2))) << "between them: an ordinary pixel";
    EXPECT_FALSE(buried(throughPixel(-3, 5, 1.2))) << "left of the image";
    EXPECT_FALSE(buried(throughPixel(39.6, 5, 1.2))) << "rounds to column 40, past the last";
    EXPECT_TRUE(buried(throughPixel(39.4, 29.4, 1.2))) << "the last pixel";
    EXPECT_FALSE(buried(throughPixel(5, 30, 1.2))) << "below the image";
    EXPECT_FALSE(buried(dvec3(0.0, 0.0, -1.2))) << "behind the camera";
    EXPECT_FALSE(buried(dvec3(std::nan(""), 0.0, 1.2))) << "a NaN point";
    gi::RealDepthView none = view;
    none.data = nullptr;
    EXPECT_FALSE(gi::isBuriedUnderRealSurface(throughPixel(5, 5, 1.2), none)) << "no depth map";

    // The tolerance grows with the depth as sigma(z): at 3 m, 3 (0.0012 + 0.0019 * 2.6^2) = 0.042132 m.
    image.at(20, 20) = 3.0f;
    const double far = 3.0 * (0.0012 + 0.0019 * 2.6 * 2.6);
    EXPECT_FALSE(gi::isBuriedUnderRealSurface(throughPixel(20, 20, 3.0 + 0.99 * far), image.view()));
    EXPECT_TRUE(gi::isBuriedUnderRealSurface(throughPixel(20, 20, 3.0 + 1.01 * far), image.view()));
}

TEST(BuriedSparsePoints, ProjectsWithTheCameraPoseAndANegativeFy) {
    // Top half (rows 0-14) at 1 m, bottom half at 2 m. ICL-NUIM's fy < 0 maps camera y > 0 to the top.
    DepthImage image;
    for (int v = 15; v < kHeight; ++v)
        for (int u = 0; u < kWidth; ++u) image.at(u, v) = 2.0f;
    const dvec3 p(0.0, 0.1, 1.5); // row 14.5 + fy 0.1 / 1.5: 11.2 (fy < 0, 1 m: buried) or 17.8 (2 m: not)
    EXPECT_TRUE(gi::isBuriedUnderRealSurface(p, image.view(-kFocal)));
    EXPECT_FALSE(gi::isBuriedUnderRealSurface(p, image.view(kFocal)));

    // The same points in a world frame: camera_T_world carries them into the camera first.
    const glm::dmat4 world_T_camera =
        glm::rotate(glm::translate(glm::dmat4(1.0), dvec3(0.3, -0.2, 1.0)), 0.7, glm::normalize(dvec3(1, 2, 3)));
    gi::RealDepthView posed = image.view(-kFocal);
    posed.camera_T_world = glm::mat4(glm::inverse(world_T_camera));
    const std::vector<dvec3> cameraPoints{p, dvec3(0.0, 0.1, 0.9), throughPixel(5, 5, 1.2, -kFocal),
                                          throughPixel(5, 25, 1.2, -kFocal), throughPixel(5, 25, 2.2, -kFocal)};
    const std::array<std::uint8_t, 5> expected{1, 0, 1, 0, 1};
    std::vector<dvec3> world;
    for (const dvec3& c : cameraPoints) world.push_back(dvec3(world_T_camera * glm::dvec4(c, 1.0)));
    std::vector<std::uint8_t> flags(world.size(), 7);
    gi::markBuriedInto(world, posed, flags);
    for (std::size_t i = 0; i < flags.size(); ++i) EXPECT_EQ(flags[i], expected[i]) << "point " << i;
}

namespace {

// A vertex at the origin (normal +z) and its 8 neighbours on the x axis at 1..8 cm, normals +z, in
// order: eq. 12's distance terms are 1 - d_j / d_max = 7/8, 6/8, ..., 0 (d_max = 8 cm). Neighbours
// 1 and 4 are buried and gathered nothing; the others carry radiance j + 1.
struct EightNeighbours {
    std::vector<ref::Receiver> sparse = std::vector<ref::Receiver>(8);
    std::vector<ref::VplPair> vpls = std::vector<ref::VplPair>(8);
    std::vector<std::uint8_t> buried = std::vector<std::uint8_t>(8, 0);
    EightNeighbours() {
        for (std::size_t j = 0; j < 8; ++j) {
            sparse[j].position = dvec3(0.01 * double(j + 1), 0.0, 0.0);
            vpls[j].diffuse.position = sparse[j].position + dvec3(0.0, 0.0, 1.0);
            vpls[j].diffuse.radiance = dvec3(double(j + 1));
        }
        for (std::size_t j : {1u, 4u}) {
            buried[j] = 1;
            vpls[j].diffuse.radiance = dvec3(0.0);
        }
    }
    double vertexRadiance(std::span<const std::uint8_t> flags, const dvec3& normal = dvec3(0, 0, 1)) const {
        using List = std::array<std::uint32_t, 8>;
        std::vector<ref::VplPair> out;
        ref::interpolateVerticesInto(std::vector<dvec3>{dvec3(0.0)}, std::vector<dvec3>{normal},
                                     std::vector<List>{List{0, 1, 2, 3, 4, 5, 6, 7}}, sparse, vpls, out, false, flags);
        return out[0].diffuse.radiance.x;
    }
};

} // namespace

TEST(BuriedSparsePoints, BuriedNeighboursGetZeroWeightInTheVertexInterpolation) {
    EightNeighbours n;
    // Kept weights 7, 5, 4, 2, 1, 0 (sum 19) over radiances 1, 3, 4, 6, 7, 8: 57 / 19 = 3.
    EXPECT_NEAR(n.vertexRadiance(n.buried), 57.0 / 19.0, 1e-12);
    // Without the rule (the paper): all weights 7..0 (sum 28), the buried ones' zeros pull it to 57 / 28.
    EXPECT_NEAR(n.vertexRadiance({}), 57.0 / 28.0, 1e-12);
    // All buried: the paper's weights, exactly as without the rule.
    const std::vector<std::uint8_t> all(8, 1);
    EXPECT_EQ(n.vertexRadiance(all), n.vertexRadiance({}));
    // Only the farthest kept: its distance term is 0, so G6a's normal term alone gives it weight 1.
    std::vector<std::uint8_t> allButLast(8, 1);
    allButLast[7] = 0;
    EXPECT_NEAR(n.vertexRadiance(allButLast), 8.0, 1e-12);
    // ... and facing away from the vertex too: G6b takes the nearest kept neighbour (not neighbour 0).
    n.sparse[7].normal = dvec3(0, 0, -1);
    EXPECT_NEAR(n.vertexRadiance(allButLast), 8.0, 1e-12);
}
