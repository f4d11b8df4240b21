// mr::estimatedDirectLight: which part of a room-light estimate becomes the virtual objects' direct light (the rule
// against counting an emitter twice) and its position and power in the renderer's units. The expectations are the
// closed forms of a point light: irradiance facing it at distance d is I / d^2 with I = power / (4 pi) W/sr, and the
// renderer's radiance is displayed times 2^exposureStops, so a virtual surface matches a real one of the same
// albedo when the renderer's irradiance at the reference point is E0 / 2^exposureStops.
#include <lightskin/mr/EstimatedLight.h>
#include <lightskin/roomlight/SphericalHarmonics.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <limits>
#include <numbers>

using namespace lightskin;
using roomlight::DominantSource;

namespace {

constexpr double kPi = std::numbers::pi;
const glm::dvec3 kReference{1.0, 2.0, 0.5};

/// The renderer's irradiance facing `light` at the reference point, times 2^exposureStops: camera units.
glm::dvec3 cameraIrradianceAtReference(const mr::EstimatedDirectLight& light, float exposureStops) {
    const glm::dvec3 toLight = glm::dvec3(light.positionWorld) - kReference;
    return glm::dvec3(light.power) / (4.0 * kPi) / glm::dot(toLight, toLight) * std::exp2(double(exposureStops));
}

roomlight::LightEstimate estimateWith(DominantSource source) {
    roomlight::LightEstimate e;
    e.state = roomlight::EstimateState::Fitted;
    e.referencePointWorld = kReference;
    e.dominant.source = source;
    e.dominant.directionWorld = glm::normalize(glm::dvec3(0.3, -0.4, 0.8));
    e.dominant.colour = {1.2, 1.0, 0.8};
    e.dominant.intensity = 0.9;
    // A consistent SH: the light's own band 0 (E0 / 4 on average over normals, times sqrt(4 pi)) plus an ambient.
    e.sh[0] = (e.dominant.colour * e.dominant.intensity / 4.0 + glm::dvec3(0.3)) * std::sqrt(4.0 * kPi);
    return e;
}

// Relative tolerance of the float conversions (positions and powers are floats): a few ulps of 1e-7.
constexpr double kFloat = 1e-5;

void expectNear(const glm::dvec3& a, const glm::dvec3& b, double relative) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], relative * std::abs(b[c]) + 1e-12) << "channel " << c;
}

} // namespace

TEST(EstimatedLight, ALocalLightWithAPositionIsDrawnThereWithItsIrradianceAtTheReference) {
    roomlight::LightEstimate e = estimateWith(DominantSource::LocalLight);
    const glm::dvec3 at = kReference + 2.0 * e.dominant.directionWorld; // 2 m away
    e.dominant.positionWorld = at;
    const render::EstimatedLightSettings settings; // distant beyond 5 m
    for (float stops : {0.0f, 1.5f, -2.0f}) {
        const mr::EstimatedDirectLight light = mr::estimatedDirectLight(e, settings, stops);
        EXPECT_EQ(light.use, mr::EstimatedLightUse::Dominant);
        expectNear(glm::dvec3(light.positionWorld), at, kFloat);
        EXPECT_NEAR(light.distanceMetres, 2.0, 2.0 * kFloat);
        // E0 * colour per channel, back in camera units; and the closed form of the power: 4 pi E0 c d^2 / 2^s.
        expectNear(cameraIrradianceAtReference(light, stops), e.dominant.colour * e.dominant.intensity, 4 * kFloat);
        EXPECT_NEAR(light.power.x, 4.0 * kPi * 0.9 * 1.2 * 4.0 / std::exp2(double(stops)), 1e-4);
    }
}

TEST(EstimatedLight, ADistantLightIsPlacedAtTheSettingsDistanceAlongItsDirection) {
    roomlight::LightEstimate e = estimateWith(DominantSource::LocalLight); // no position: directional
    render::EstimatedLightSettings settings;
    settings.distantLightMetres = 4.0f;
    const mr::EstimatedDirectLight light = mr::estimatedDirectLight(e, settings, 0.0f);
    EXPECT_EQ(light.use, mr::EstimatedLightUse::Dominant);
    expectNear(glm::dvec3(light.positionWorld), kReference + 4.0 * e.dominant.directionWorld, kFloat);
    expectNear(cameraIrradianceAtReference(light, 0.0f), e.dominant.colour * e.dominant.intensity, 4 * kFloat);
    // A position beyond that distance is brought in to it, keeping E0 at the reference.
    e.dominant.positionWorld = kReference + 40.0 * e.dominant.directionWorld;
    const mr::EstimatedDirectLight far = mr::estimatedDirectLight(e, settings, 0.0f);
    EXPECT_NEAR(far.distanceMetres, 4.0, 4.0 * kFloat);
    expectNear(cameraIrradianceAtReference(far, 0.0f), e.dominant.colour * e.dominant.intensity, 4 * kFloat);
}

TEST(EstimatedLight, AnSHLinearBandLightIsDrawn) {
    const roomlight::LightEstimate e = estimateWith(DominantSource::ShLinearBand);
    const mr::EstimatedDirectLight light = mr::estimatedDirectLight(e, {}, 0.0f);
    EXPECT_EQ(light.use, mr::EstimatedLightUse::Dominant);
    expectNear(cameraIrradianceAtReference(light, 0.0f), e.dominant.colour * e.dominant.intensity, 4 * kFloat);
}

// The rule against counting twice: a visible emitter's light reaches the objects through its own pixels' VALs.
TEST(EstimatedLight, AVisibleEmitterIsNotDrawnTwice) {
    roomlight::LightEstimate e = estimateWith(DominantSource::Emitter);
    e.dominant.positionWorld = kReference + glm::dvec3(0.0, 0.0, 2.0);
    const mr::EstimatedDirectLight alone = mr::estimatedDirectLight(e, {}, 0.0f);
    EXPECT_EQ(alone.use, mr::EstimatedLightUse::None);
    EXPECT_EQ(alone.power, glm::vec3(0.0f));
    expectNear(glm::dvec3(alone.positionWorld), kReference, kFloat);

    // With a free light beside it (out of view: no VAL carries it), the free light is drawn instead.
    e.localLightIrradiance = {0.3, 0.2, 0.1}; // within 4 x the mean irradiance of estimateWith's SH
    e.localLightDirectionWorld = glm::normalize(glm::dvec3(-1.0, 0.0, 1.0));
    e.localLightPositionWorld = kReference + 1.5 * e.localLightDirectionWorld;
    const mr::EstimatedDirectLight free = mr::estimatedDirectLight(e, {}, 0.0f);
    EXPECT_EQ(free.use, mr::EstimatedLightUse::FreeLight);
    expectNear(glm::dvec3(free.positionWorld), *e.localLightPositionWorld, kFloat);
    expectNear(cameraIrradianceAtReference(free, 0.0f), e.localLightIrradiance, 4 * kFloat);
}

TEST(EstimatedLight, NoDominantLightOrABrokenOneDrawsNothing) {
    const roomlight::LightEstimate neutral; // NeutralAmbient, DominantSource::None
    EXPECT_EQ(mr::estimatedDirectLight(neutral, {}, 0.0f).use, mr::EstimatedLightUse::None);
    EXPECT_EQ(mr::estimatedDirectLight(neutral, {}, 0.0f).power, glm::vec3(0.0f));
    roomlight::LightEstimate nan = estimateWith(DominantSource::LocalLight);
    nan.dominant.intensity = std::numeric_limits<double>::quiet_NaN();
    const mr::EstimatedDirectLight light = mr::estimatedDirectLight(nan, {}, 0.0f);
    EXPECT_EQ(light.use, mr::EstimatedLightUse::None);
    EXPECT_EQ(light.power, glm::vec3(0.0f));
}

// A fit that broke (a negative mean irradiance, or a light brighter than all the light there is) draws nothing.
TEST(EstimatedLight, AnUnphysicalEstimateIsRejected) {
    roomlight::LightEstimate e = estimateWith(DominantSource::LocalLight);
    EXPECT_EQ(mr::estimatedDirectLight(e, {}, 0.0f).use, mr::EstimatedLightUse::Dominant);
    roomlight::LightEstimate negative = e;
    negative.sh[0].z = -0.01;
    EXPECT_EQ(mr::estimatedDirectLight(negative, {}, 0.0f).use, mr::EstimatedLightUse::Rejected);
    EXPECT_EQ(mr::estimatedDirectLight(negative, {}, 0.0f).power, glm::vec3(0.0f));
    // E0 exactly 4 x the mean (a single light, no ambient) is physical; 10 % more is not.
    roomlight::LightEstimate alone = e;
    alone.sh[0] = alone.dominant.colour * alone.dominant.intensity / 4.0 * std::sqrt(4.0 * kPi);
    EXPECT_EQ(mr::estimatedDirectLight(alone, {}, 0.0f).use, mr::EstimatedLightUse::Dominant);
    alone.dominant.intensity *= 1.1;
    EXPECT_EQ(mr::estimatedDirectLight(alone, {}, 0.0f).use, mr::EstimatedLightUse::Rejected);
}

// The `light` view (drawLightEstimateInto). A 320x240 image: the probe ball's radius is 240 / 8 = 30 px and its
// centre (34, 206).
namespace {

constexpr int kProbeU = 34, kProbeV = 206, kProbeRadius = 30;

CameraIntrinsics viewCamera() {
    CameraIntrinsics k;
    k.width = 320;
    k.height = 240;
    k.fx = k.fy = 262.5;
    k.cx = 159.5;
    k.cy = 119.5;
    return k;
}

/// A camera at the origin looking along world +x, image down = world -z (world z up).
Pose horizontalCamera() {
    glm::dmat4 m(1.0);
    m[0] = glm::dvec4(0.0, -1.0, 0.0, 0.0); // camera x (right) = world -y
    m[1] = glm::dvec4(0.0, 0.0, -1.0, 0.0); // camera y (down) = world -z
    m[2] = glm::dvec4(1.0, 0.0, 0.0, 0.0);  // camera z (forward) = world +x
    return Pose::fromMatrix(m);
}

/// Drawn in yellow (anti-aliased lines blend at their edges; the background in these tests is black).
bool isYellow(const cv::Vec3b& c) { return c[0] < 80 && c[1] > 150 && c[2] > 150; }

} // namespace

TEST(LightEstimateView, AUniformEnvironmentShowsTheBallAtRhoOverPiTimesE) {
    // E(n) = pi everywhere: sh[0] = E / Y_00 = pi * 2 sqrt(pi). The ball shows rho / pi * E = 0.8 linear, which
    // sRGB encodes as 1.055 * 0.8^(1/2.4) - 0.055 = 0.9063 -> 231 of 255.
    roomlight::LightEstimate e;
    e.sh[0] = glm::dvec3(kPi * 2.0 * std::sqrt(kPi));
    cv::Mat image(240, 320, CV_8UC3, cv::Scalar(10, 20, 30));
    mr::drawLightEstimateInto(image, e, viewCamera(), horizontalCamera());
    for (const cv::Point p : {cv::Point(kProbeU, kProbeV), cv::Point(kProbeU + 20, kProbeV - 10)})
        EXPECT_EQ(image.at<cv::Vec3b>(p), cv::Vec3b(231, 231, 231)) << p;
    EXPECT_EQ(image.at<cv::Vec3b>(kProbeV, kProbeU + kProbeRadius + 2), cv::Vec3b(10, 20, 30)); // outside the ball
}

TEST(LightEstimateView, TheBallIsLitFromTheWorldDirectionOfTheLight) {
    // Order-2 SH of a directional light (Ramamoorthi & Hanrahan): E(theta) = E0 (1/4 + 1/2 cos + 5/16 P2(cos)),
    // P2 = (3 cos^2 - 1) / 2. With E0 = 2 and rho / pi = 0.8 / pi, sRGB-encoded: 3 px inside the ball's rim at its
    // top the normal is 0.9 toward the light above (E = 0.92 E0: 182), at its bottom 0.9 away (0.023 E0: 28); its
    // centre facing a light behind the camera 1.0625 E0 (194), a light behind the ball 0.0625 E0 (50).
    roomlight::LightEstimate e;
    roomlight::addDirectionalLight(e.sh, {0.0, 0.0, 1.0}, glm::dvec3(2.0));
    cv::Mat image(240, 320, CV_8UC3, cv::Scalar(0, 0, 0));
    mr::drawLightEstimateInto(image, e, viewCamera(), horizontalCamera());
    const int top = image.at<cv::Vec3b>(kProbeV - kProbeRadius + 3, kProbeU)[1];
    const int bottom = image.at<cv::Vec3b>(kProbeV + kProbeRadius - 3, kProbeU)[1];
    EXPECT_GT(top, 150);
    EXPECT_LT(bottom, 40);
    // The ball faces the camera: a light behind the camera (world -x) lights its centre, one behind the ball does not.
    for (const double towardX : {-1.0, 1.0}) {
        roomlight::LightEstimate behind;
        roomlight::addDirectionalLight(behind.sh, {towardX, 0.0, 0.0}, glm::dvec3(2.0));
        image.setTo(cv::Scalar(0, 0, 0));
        mr::drawLightEstimateInto(image, behind, viewCamera(), horizontalCamera());
        const int centre = image.at<cv::Vec3b>(kProbeV, kProbeU)[1];
        if (towardX < 0.0)
            EXPECT_GT(centre, 150);
        else
            EXPECT_LT(centre, 60);
    }
}

TEST(LightEstimateView, TheDominantLightIsARingWhereItIsSeenElseAnArrowFromTheBall) {
    roomlight::LightEstimate e;
    e.sh[0] = glm::dvec3(1.0);
    e.dominant.source = DominantSource::LocalLight;
    e.dominant.intensity = 1.0;
    // In view: 2 m ahead (world +x), 0.5 m left (world +y) and 0.3 m up: pixel (159.5 + 262.5 * -0.5 / 2,
    // 119.5 + 262.5 * -0.3 / 2) = (93.9, 80.1); the ring's radius is max(4, 30 / 3) = 10 px.
    e.dominant.positionWorld = glm::dvec3(2.0, 0.5, 0.3);
    e.dominant.directionWorld = glm::normalize(*e.dominant.positionWorld);
    cv::Mat image(240, 320, CV_8UC3, cv::Scalar(0, 0, 0));
    mr::drawLightEstimateInto(image, e, viewCamera(), horizontalCamera());
    bool ring = false;
    for (int du = 8; du <= 12; ++du) ring = ring || isYellow(image.at<cv::Vec3b>(80, 94 + du));
    EXPECT_TRUE(ring);
    EXPECT_EQ(image.at<cv::Vec3b>(80, 94), cv::Vec3b(0, 0, 0)); // a ring, not a disc

    // Behind the camera and above: an arrow from the ball's centre pointing up in the image.
    e.dominant.positionWorld = glm::dvec3(-2.0, 0.0, 2.0);
    e.dominant.directionWorld = glm::normalize(*e.dominant.positionWorld);
    image.setTo(cv::Scalar(0, 0, 0));
    mr::drawLightEstimateInto(image, e, viewCamera(), horizontalCamera());
    EXPECT_TRUE(isYellow(image.at<cv::Vec3b>(kProbeV - kProbeRadius - 10, kProbeU)));
    EXPECT_FALSE(isYellow(image.at<cv::Vec3b>(kProbeV + kProbeRadius + 3, kProbeU)));
}
