#pragma once
// The room's light as estimated from one RGB-D frame (RoomLightEstimator.h), in the camera's
// radiometric units: a real Lambertian surface of albedo rho at the reference point with unit normal n
// shows the linear (sRGB-decoded) pixel value rho / pi * E(n), E the irradiance below. An exposure or
// white-balance change of the camera scales these numbers exactly as it scales the real pixels.
// Frames: world (the pose's target frame), metres. Never NaN: see EstimateState.

#include <lightskin/roomlight/SphericalHarmonics.h>

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <optional>

namespace lightskin::roomlight {

/// Where this frame's estimate comes from.
enum class EstimateState : std::uint8_t {
    Fitted,         ///< fitted to this frame (and temporally filtered with the previous ones)
    KeptLast,       ///< this frame could not be used (FrameProblem): the last estimate, unchanged
    NeutralAmbient, ///< no usable frame yet: a uniform white irradiance (Options::neutralIrradiance)
};
const char* toString(EstimateState state) noexcept;

/// Why a frame was not fitted (None when it was).
enum class FrameProblem : std::uint8_t {
    None,
    NoDepth,       ///< fewer than Options::minSamples pixels with valid depth and a normal
    Dark,          ///< the median valid pixel is below Options::darkLevel (lens covered, lights off)
    MostlyClipped, ///< more than Options::maxClippedFraction of the valid pixels are clipped
    FitFailed,     ///< the robust fit was singular or not finite (kept out of the estimate)
    /// The fit converged but is not to be trusted: its residual is above Options::maxResidual, or the estimate is
    /// not physical (a negative mean irradiance in a channel, a negative light)
    PoorFit,
};
const char* toString(FrameProblem problem) noexcept;

/// Which part of the model the dominant light is.
enum class DominantSource : std::uint8_t {
    None,        ///< no light stands out: intensity 0, direction (0,0,1) by convention
    LocalLight,  ///< the fitted free point (or directional) light
    Emitter,     ///< a clipped region the camera sees (AreaEmitter)
    ShLinearBand ///< extracted from the SH alone (extractDominantLight)
};
const char* toString(DominantSource source) noexcept;

/// The light virtual objects at the reference point should cast shadows from.
struct DominantLight {
    glm::dvec3 directionWorld{0.0, 0.0, 1.0}; ///< unit, from the reference point toward the light
    std::optional<glm::dvec3> positionWorld;  ///< metres; none for a distant light
    glm::dvec3 colour{1.0};                   ///< linear RGB with mean 1 (colour * intensity = E0 per channel)
    double intensity = 0.0; ///< E0: irradiance at the reference point on a surface facing the light (mean of RGB)
    DominantSource source = DominantSource::None;
};

/// A light source the camera sees: a clipped region with valid depth, modelled as a flat Lambertian
/// emitter (disc) of the region's area at its centroid.
struct AreaEmitter {
    glm::dvec3 positionWorld{0.0};         ///< centroid, metres
    glm::dvec3 normalWorld{0.0, 0.0, 1.0}; ///< unit, the side that emits
    double areaSquareMetres = 0.0;
    /// Radiance recovered from the light it casts on the real surfaces (the pixels themselves are clipped),
    /// camera units per channel.
    glm::dvec3 radiance{0.0};
    int sampleCount = 0; ///< clipped samples in the region
};

inline constexpr int kMaxEmitters = 2;

struct LightEstimate {
    EstimateState state = EstimateState::NeutralAmbient;
    FrameProblem problem = FrameProblem::None;
    /// Irradiance environment at referencePointWorld: E(n) = sum_k sh[k] Y_k(n) per channel (SphericalHarmonics.h),
    /// the local light, the emitters and the fitted ambient projected together.
    ShRgb sh{};
    glm::dvec3 referencePointWorld{0.0};
    /// The distant ambient part of sh alone (irradiance coefficients): what is left for virtual objects once the
    /// dominant light and the emitters are drawn as lights of their own.
    ShRgb ambientSh{};
    DominantLight dominant;
    /// The free light of the model (DominantSource::LocalLight): irradiance facing it at the reference point
    /// (camera units per channel, zero when the fit found none) and its position (none when distant).
    glm::dvec3 localLightIrradiance{0.0};
    glm::dvec3 localLightDirectionWorld{0.0, 0.0, 1.0};
    std::optional<glm::dvec3> localLightPositionWorld;
    std::array<AreaEmitter, kMaxEmitters> emitters{};
    int emitterCount = 0;
    /// Robust relative residual of the fit: sqrt(sum w (observed - predicted)^2 / sum w observed^2) over the
    /// fitted samples and channels (0 = perfect). The last fitted frame's value when kept.
    double residual = 0.0;
    /// Per-channel gain of the camera between the previous fitted frame and this one (exposure and white
    /// balance), measured on the real surfaces; 1 on the first frame.
    glm::dvec3 exposureGain{1.0};
    int samplesFitted = 0;
};

} // namespace lightskin::roomlight
