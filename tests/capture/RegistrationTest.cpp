// Software depth-to-colour registration (capture/Registration.h) against an exact synthetic case:
// a tilted plane and a box seen by a depth camera and a colour camera with a known extrinsic. The
// depth image and the colour camera's true depth are ray-cast analytically in this file (ray-plane
// and ray-box slab intersections in double precision), independent of the registrar's code path.
#include <lightskin/capture/Registration.h>
#include <lightskin/core/Error.h>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace lightskin::test {
namespace {

// The scene, in the depth camera's frame (metres): the plane z = 2 + 0.2 x + 0.3 y (1.5-2.5 m over
// the view) and an axis-aligned box in front of it.
const glm::dvec3 kPlaneNormal{0.2, 0.3, -1.0};
constexpr double kPlaneOffset = -2.0; // n . X = kPlaneOffset
const glm::dvec3 kBoxMin{-0.15, -0.10, 1.20}, kBoxMax{0.10, 0.15, 1.45};
// A hole in the depth image (a dark surface the sensor missed), depth pixels [400, 440) x [100, 140).
const cv::Rect kHole{400, 100, 40, 40};
constexpr double kScale = 0.001; // millimetres

enum Surface : std::uint8_t { kNone = 0, kPlane = 1, kBoxFront = 2, kBoxSide = 3 };

struct Hit {
    double t = std::numeric_limits<double>::infinity();
    Surface surface = kNone;
};

Hit hitPlane(const glm::dvec3& o, const glm::dvec3& d) {
    const double denominator = glm::dot(kPlaneNormal, d);
    Hit h;
    if (std::abs(denominator) < 1e-12) return h;
    const double t = (kPlaneOffset - glm::dot(kPlaneNormal, o)) / denominator;
    if (t > 1e-9) h = {t, kPlane};
    return h;
}

Hit hitBox(const glm::dvec3& o, const glm::dvec3& d) {
    double near = -std::numeric_limits<double>::infinity(), far = std::numeric_limits<double>::infinity();
    int axis = -1;
    for (int a = 0; a < 3; ++a) {
        if (std::abs(d[a]) < 1e-15) {
            if (o[a] < kBoxMin[a] || o[a] > kBoxMax[a]) return {};
            continue;
        }
        double t0 = (kBoxMin[a] - o[a]) / d[a], t1 = (kBoxMax[a] - o[a]) / d[a];
        if (t0 > t1) std::swap(t0, t1);
        if (t0 > near) {
            near = t0;
            axis = a;
        }
        far = std::min(far, t1);
    }
    Hit h;
    if (near <= far && near > 1e-9) h = {near, axis == 2 ? kBoxFront : kBoxSide};
    return h;
}

Hit hitScene(const glm::dvec3& o, const glm::dvec3& d) {
    const Hit p = hitPlane(o, d), b = hitBox(o, d);
    return b.t < p.t ? b : p;
}

struct Rig {
    CameraIntrinsics depth{640, 480, 575.8, 577.1, 314.2, 243.6, {}};
    CameraIntrinsics colour{640, 480, 525.0, 524.2, 322.4, 250.9, {}};
    Pose colour_T_depth;
    Rig() {
        // 1.5 degrees about a skew axis and a Kinect-like baseline with small y/z offsets.
        const glm::dvec3 axis = glm::normalize(glm::dvec3(0.3, 1.0, 0.2));
        colour_T_depth = Pose(glm::angleAxis(glm::radians(1.5), axis), glm::dvec3(0.025, -0.002, 0.003));
    }
};

/// The depth image the depth camera sees: z of the nearest hit along each pixel centre's ray,
/// rounded to millimetres; the hole rectangle is 0.
cv::Mat renderDepth(const Rig& rig) {
    cv::Mat depth(rig.depth.height, rig.depth.width, CV_16UC1, cv::Scalar(0));
    for (int v = 0; v < depth.rows; ++v)
        for (int u = 0; u < depth.cols; ++u) {
            if (kHole.contains(cv::Point(u, v))) continue;
            const glm::dvec3 d = rig.depth.backProject(u, v, 1.0);
            const Hit h = hitScene(glm::dvec3(0.0), d);
            if (h.surface == kNone) continue;
            depth.at<std::uint16_t>(v, u) = std::uint16_t(std::lround(h.t * d.z / kScale));
        }
    return depth;
}

struct ColourTruth {
    cv::Mat z;         // CV_64F: depth along the colour camera's axis of the surface each pixel sees
    cv::Mat surface;   // CV_8U: Surface
    cv::Mat seen;      // CV_8U: 1 = that point has a sample in the depth image (in view, not occluded, not in the hole)
    cv::Mat contested; // CV_8U: 1 = the box is seen, and the plane behind it along this ray has a depth sample
};

/// Whether world point p (depth frame) yields a depth sample: inside the depth image, first hit
/// along the depth camera's ray, outside the hole.
bool sampledByDepth(const Rig& rig, const glm::dvec3& p) {
    const glm::dvec2 pixel = rig.depth.project(p);
    if (!(pixel.x >= -0.5 && pixel.x < rig.depth.width - 0.5 && pixel.y >= -0.5 && pixel.y < rig.depth.height - 0.5))
        return false;
    if (kHole.contains(cv::Point(int(std::lround(pixel.x)), int(std::lround(pixel.y))))) return false;
    const glm::dvec3 d = p / p.z;
    const Hit h = hitScene(glm::dvec3(0.0), d);
    return std::abs(h.t - p.z) < 1e-6;
}

ColourTruth renderColourTruth(const Rig& rig) {
    const Pose depth_T_colour = rig.colour_T_depth.inverse();
    const glm::dvec3 origin = depth_T_colour.transformPoint(glm::dvec3(0.0));
    ColourTruth t;
    t.z.create(rig.colour.height, rig.colour.width, CV_64FC1);
    t.surface.create(t.z.size(), CV_8UC1);
    t.seen.create(t.z.size(), CV_8UC1);
    t.contested.create(t.z.size(), CV_8UC1);
    for (int v = 0; v < t.z.rows; ++v)
        for (int u = 0; u < t.z.cols; ++u) {
            const glm::dvec3 d = depth_T_colour.transformDirection(rig.colour.backProject(u, v, 1.0));
            const Hit h = hitScene(origin, d);
            t.surface.at<std::uint8_t>(v, u) = h.surface;
            t.z.at<double>(v, u) = 0.0;
            t.seen.at<std::uint8_t>(v, u) = 0;
            t.contested.at<std::uint8_t>(v, u) = 0;
            if (h.surface == kNone) continue;
            const glm::dvec3 p = origin + h.t * d;
            t.z.at<double>(v, u) = rig.colour_T_depth.transformPoint(p).z;
            t.seen.at<std::uint8_t>(v, u) = sampledByDepth(rig, p) ? 1 : 0;
            if (h.surface != kPlane) {
                const Hit behind = hitPlane(origin, d);
                if (behind.surface == kPlane && sampledByDepth(rig, origin + behind.t * d))
                    t.contested.at<std::uint8_t>(v, u) = 1;
            }
        }
    return t;
}

/// True when every pixel within `radius` (Chebyshev) is inside the image and satisfies `f`.
template <typename F>
bool allAround(const cv::Mat& image, int u, int v, int radius, F f) {
    for (int dv = -radius; dv <= radius; ++dv)
        for (int du = -radius; du <= radius; ++du) {
            const int x = u + du, y = v + dv;
            if (x < 0 || y < 0 || x >= image.cols || y >= image.rows || !f(x, y)) return false;
        }
    return true;
}

TEST(RegistrationTest, PlaneAndBoxRegisterWithinTheDerivedPixelAndMetreBounds) {
    const Rig rig;
    const cv::Mat depth = renderDepth(rig);
    const ColourTruth truth = renderColourTruth(rig);
    const auto registrar =
        capture::DepthRegistrar::create({rig.depth, rig.colour, rig.colour_T_depth, "synthetic rig"});
    cv::Mat registered;
    registrar.registerInto(depth, kScale, registered);
    ASSERT_EQ(registered.type(), CV_16UC1);
    ASSERT_EQ(registered.size(), cv::Size(640, 480));

    // Metres. A depth sample is its surface point with z quantised to 1 mm (<= 0.5 mm along the
    // ray, i.e. <= 0.5 mm * |ray| <= 0.62 mm in space at this field of view, |ray| <= 1.23), landing
    // on the nearest colour pixel: its exact projection is within 0.5 px of the pixel centre per
    // axis (plus the quantisation's parallax, 525 px * 0.025 m * 0.0005 m / (1.2 m)^2 < 0.01 px).
    // On the same surface the true depth at the pixel centre therefore differs from the sample's
    // by at most 0.51 * (|dz/du| + |dz/dv|) (the local gradient of the true depth, m/px), plus the
    // 0.62 mm quantisation and the registered value's own rounding to 0.5 mm. Pixels within 2 px
    // of another surface, of an occlusion shadow or the image border are not "interior" (a sample
    // moves <= 0.51 px, so one from another surface cannot land 2 px inside this one).
    int interior = 0, interiorHoles = 0, worseThanBound = 0, contested = 0, shadowPixels = 0, shadowFilled = 0;
    double worstRatio = 0.0;
    for (int v = 0; v < registered.rows; ++v)
        for (int u = 0; u < registered.cols; ++u) {
            const std::uint8_t surface = truth.surface.at<std::uint8_t>(v, u);
            const double got = registered.at<std::uint16_t>(v, u) * kScale;
            const bool sameSurface = allAround(truth.surface, u, v, 2, [&](int x, int y) {
                return truth.surface.at<std::uint8_t>(y, x) == surface && truth.seen.at<std::uint8_t>(y, x) == 1;
            });
            if (surface != kNone && sameSurface) {
                double gu = 0.0, gv = 0.0;
                for (int d = -2; d < 2; ++d) {
                    gu = std::max(gu, std::abs(truth.z.at<double>(v, u + d + 1) - truth.z.at<double>(v, u + d)));
                    gv = std::max(gv, std::abs(truth.z.at<double>(v + d + 1, u) - truth.z.at<double>(v + d, u)));
                }
                const double bound = 0.51 * (gu + gv) + 0.00062 + 0.0005;
                if (got == 0.0) {
                    // No cracks on the plane and the box front: there a depth pixel step maps to
                    // (525 / 575.8) * (z_depth / z_colour) * (1 +- tilt) < 0.96 colour px (z ratio
                    // within 1 +- 0.003 / 1.2, rotation shear 0.91 * sin 1.5 deg = 0.024 px), so
                    // every colour pixel's unit square holds a sample. (The box sides are seen at
                    // grazing angles, more stretched in one camera: splatting may leave gaps there.)
                    if (surface != kBoxSide) ++interiorHoles;
                    continue;
                }
                ++interior;
                const double error = std::abs(got - truth.z.at<double>(v, u));
                worstRatio = std::max(worstRatio, error / bound);
                if (error > bound) ++worseThanBound;
                if (truth.contested.at<std::uint8_t>(v, u))
                    ++contested; // plane samples landed here too: the z-buffer chose
            }
            // Occlusion shadows and the hole: the colour camera sees surface the depth camera did not
            // sample; 2 px inside such a region no sample can land (each moves <= 0.51 px): holes stay holes.
            if (surface != kNone &&
                allAround(truth.seen, u, v, 2, [&](int x, int y) { return truth.seen.at<std::uint8_t>(y, x) == 0; })) {
                ++shadowPixels;
                if (got != 0.0) ++shadowFilled;
            }
        }
    std::printf("interior %d, worst error / bound %.3f, contested %d, shadow/hole pixels %d\n", interior, worstRatio,
                contested, shadowPixels);
    EXPECT_GT(interior, 200000) << "most of the image is interior surface";
    EXPECT_EQ(worseThanBound, 0);
    EXPECT_EQ(interiorHoles, 0);
    // The case exercises the z-buffer (box pixels that plane samples also reach, the baseline's
    // parallax: a strip 525 * 0.025 * (1/1.2 - 1/2) ~ 4.4 px wide along the box's ~110 rows, ~2.4 px
    // of it interior after the 2 px margin: ~260 px) and hole keeping (the occlusion shadow and the
    // 40x40 px hole, > 1000 px after the 2 px margin).
    EXPECT_GT(contested, 150);
    EXPECT_GT(shadowPixels, 1000);
    EXPECT_EQ(shadowFilled, 0);

    // Pixels: the box's silhouette. A sample lands within 0.51 px (per axis) of its exact
    // projection, so every registered box pixel is the true box or next to it (1 px), and every
    // true box pixel 1 px inside its silhouette (and sampled) is registered as box. Box 1.2-1.5 m,
    // plane >= 1.53 m.
    int boxOutside = 0, boxMissing = 0, boxPixels = 0;
    for (int v = 0; v < registered.rows; ++v)
        for (int u = 0; u < registered.cols; ++u) {
            const std::uint16_t value = registered.at<std::uint16_t>(v, u);
            const bool registeredBox = value != 0 && value * kScale < 1.5;
            const auto isBox = [&](int x, int y) {
                const std::uint8_t s = truth.surface.at<std::uint8_t>(y, x);
                return s == kBoxFront || s == kBoxSide;
            };
            if (registeredBox) {
                ++boxPixels;
                bool near = false;
                for (int dv = -1; dv <= 1 && !near; ++dv)
                    for (int du = -1; du <= 1 && !near; ++du) {
                        const int x = std::clamp(u + du, 0, 639), y = std::clamp(v + dv, 0, 479);
                        near = isBox(x, y);
                    }
                if (!near) ++boxOutside;
            } else if (allAround(truth.surface, u, v, 1, isBox) && truth.seen.at<std::uint8_t>(v, u) &&
                       truth.surface.at<std::uint8_t>(v, u) == kBoxFront) {
                ++boxMissing;
            }
        }
    EXPECT_GT(boxPixels, 5000); // the box covers ~ (0.25 * 525 / 1.3)^2 ~ 10^4 px
    EXPECT_EQ(boxOutside, 0) << "box samples registered more than 1 px outside the box";
    EXPECT_EQ(boxMissing, 0) << "box front pixels without a box sample";
}

TEST(RegistrationTest, IdentityRigReproducesTheDepthImage) {
    // Same camera, no motion: every sample maps onto its own pixel (exact round trip).
    const CameraIntrinsics k{64, 48, 60.0, 60.0, 31.5, 23.5, {}};
    const auto registrar = capture::DepthRegistrar::create({k, k, Pose(), "identity"});
    cv::Mat depth(48, 64, CV_16UC1), registered;
    cv::randu(depth, 400, 5000);
    depth(cv::Rect(10, 10, 5, 5)).setTo(0);
    registrar.registerInto(depth, 0.001, registered);
    EXPECT_EQ(cv::norm(depth, registered, cv::NORM_INF), 0.0);
    // The buffer is reused on the next frame (no per-frame allocation).
    const void* buffer = registered.data;
    registrar.registerInto(depth, 0.001, registered);
    EXPECT_EQ(static_cast<const void*>(registered.data), buffer);
}

TEST(RegistrationTest, InvalidIntrinsicsAreErrorsNamingTheSource) {
    try {
        (void)capture::DepthRegistrar::create(
            {CameraIntrinsics{}, CameraIntrinsics::kinectV1Default(), Pose(), "some.oni"});
        ADD_FAILURE() << "invalid depth intrinsics accepted";
    } catch (const Error& error) {
        EXPECT_EQ(error.source(), "some.oni");
        EXPECT_NE(error.cause().find("depth"), std::string::npos);
    }
}

} // namespace
} // namespace lightskin::test
