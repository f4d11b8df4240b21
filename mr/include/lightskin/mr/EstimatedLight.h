#pragma once
// The real room's light (roomlight::LightEstimate) as the virtual objects' direct light: which part of the
// estimate is drawn as a light, where, and how bright, in the renderer's units. docs/ROOMLIGHT.md, "In the pipeline".
//
// Units: the estimate is in the camera's radiometric units (a real Lambertian surface of albedo rho shows the linear
// pixel value rho / pi * E); the renderer's radiance L is displayed as 2^exposureStops * L. A virtual surface of
// albedo rho therefore matches the real one when the renderer's irradiance is E / 2^exposureStops: a point light at
// distance d from the reference point gives that with intensity I = E0 d^2 / 2^exposureStops (W/sr) per channel,
// power = 4 pi I.
//
// The rule against counting a light twice: the VALs (one per depth pixel) already carry the light of every surface
// the camera sees, emitters included (their clipped pixels, as indirect light). So
// - an emitter (DominantSource::Emitter: a light the camera sees, with depth) is not drawn as a direct light;
//   the fit's free light, when it has one (a light out of view or without depth), is drawn instead;
// - the free light (DominantSource::LocalLight) is drawn: no VAL carries it;
// - a light extracted from the SH's linear band (DominantSource::ShLinearBand) is drawn: the SH is fitted from the
//   shading of every surface sample, which sees the whole sphere, while the VALs cover the camera's view only (a
//   Kinect's 57 x 43 degrees, ~6 % of the sphere), so most of that directional light comes from outside the view;
// - the ambient SH is not drawn: it is the room's interreflections, which the VALs carry.

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>
#include <lightskin/render/Scene.h>
#include <lightskin/roomlight/LightEstimate.h>

#include <glm/vec3.hpp>
#include <opencv2/core/mat.hpp>

#include <cstdint>
#include <optional>

namespace lightskin::mr {

/// Which light of the estimate became the direct light (report.json "direct").
enum class EstimatedLightUse : std::uint8_t {
    None,      ///< no dominant light, or an emitter without a free light: power 0 (nothing drawn)
    Dominant,  ///< the dominant light (free light or SH linear band)
    FreeLight, ///< the dominant light is an emitter (its VALs carry it): the fit's free light instead
    /// The estimate is not physical, so nothing is drawn: a channel's mean irradiance (SH band 0) below 0, or the
    /// light's E0 above 4.2 times it (a light's irradiance max(0, n.l) E0 averages E0 / 4 over all normals, and the
    /// SH holds the light plus a non-negative rest: E0 <= 4 x the mean, 5 % slack for the filter and rounding).
    Rejected,
};
const char* toString(EstimatedLightUse use) noexcept;

struct EstimatedDirectLight {
    EstimatedLightUse use = EstimatedLightUse::None;
    glm::vec3 positionWorld{0.0f}; ///< metres; the reference point when use is None
    glm::vec3 power{0.0f};         ///< watts (the renderer's unit: power / (4 pi) W/sr), linear RGB, >= 0
    /// Distance from the reference point, metres (0 when use is None).
    float distanceMetres = 0.0f;
};

/// The direct light for `estimate` (its referencePointWorld is where the irradiance E0 holds). A light with a
/// position farther than settings.distantLightMetres, or without one (distant), is placed that far along its
/// direction with the power that keeps E0 at the reference point. Never NaN; power 0 unless use is Dominant or
/// FreeLight.
EstimatedDirectLight estimatedDirectLight(const roomlight::LightEstimate& estimate,
                                          const render::EstimatedLightSettings& settings, float exposureStops) noexcept;

/// The `light` debug view (`--view light`) over a BGR 8-bit image of the camera `k` at world_T_camera:
/// - a light probe in the lower left corner: a grey Lambertian ball (albedo kProbeAlbedo) facing the camera, each
///   pixel rho / pi * E(n) of the estimate's SH at the ball's world normal n, sRGB-encoded as the camera's pixels
///   are (the same units: a real ball of that albedo at the reference point would look so);
/// - the dominant light: a yellow ring at its position when it projects into the image, else a yellow line from the
///   probe's centre along its direction as the camera sees it; each emitter: an orange ring;
/// - the state, E0 and residual as text.
inline constexpr double kProbeAlbedo = 0.8;
void drawLightEstimateInto(cv::Mat& bgr, const roomlight::LightEstimate& estimate, const CameraIntrinsics& k,
                           const Pose& world_T_camera);

} // namespace lightskin::mr
