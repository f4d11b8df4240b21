#pragma once
// Estimates the real room's light from each RGB-D frame: an order-2 SH irradiance environment, the
// emitters the camera sees, a dominant light, filtered over time (docs/ROOMLIGHT.md has the method).
//
//   roomlight::RoomLightEstimator estimator({});
//   const roomlight::LightEstimate& light = estimator.estimate(frame, world_T_camera, objectCentreWorld);
//
// The model, per colour channel c, for a real surface sample x (world position, unit normal n):
//   observed_c(x) = a_c(s(x)) / pi * [ F_c G(x) + sum_e L_e,c G_e(x) + sum_k R_k,c Ahat_l Y_k(n) ]
//   - a_c(s): albedo of x's chromaticity segment s (the albedo model: constant albedo per segment of
//     similar chromaticity; the largest segment is taken to be neutral grey of albedo referenceAlbedo, which
//     fixes the one scale per channel that shading alone cannot tell from albedo);
//   - G: the free light, a point light at inverse distance u in direction d from the reference point
//     (u = 0: a directional light), G(x) = max(0, n.v) / |v|^3 with v = d - u (x - reference), so that
//     F_c is the irradiance it gives at the reference point facing it;
//   - G_e: emitter e (a clipped region seen with depth), the sum over its clipped samples j (at most 32, each a
//     disc of area A_j = A / count at p_j with the region's normal n_e):
//     G_e(x) = sum_j A_j max(0, n_e.(x - p_j)/r) max(0, n.(p_j - x)/r) / (r^2 + A_j/pi), r = |x - p_j|
//     (the A_j/pi makes the on-axis value exact for a disc of radiance 1 near its surface);
//   - R_k: a distant ambient radiance in SH (interreflections, sky, lights the model has no term for).
// Fitted by iteratively reweighted least squares (Tukey's biweight on the relative residual, which drops
// shadows, speculars and depth errors), alternating with the per-segment albedos; the free light's (d, u)
// by a pattern search of the fit residual (variable projection), warm-started from the last frame. The free
// light and each emitter stay only if they predict held-out image blocks better (two-fold cross-validation).
// Lights and the ambient's mean (band 0) are held non-negative per channel.
// Shadows between real surfaces are not modelled (the robust weights remove them).
//
// Threading: one estimator per stream, used from one thread. No allocation per frame after the first
// frame of a given size.

#include <lightskin/core/Pose.h>
#include <lightskin/core/RgbdFrame.h>
#include <lightskin/roomlight/LightEstimate.h>

#include <memory>
#include <optional>

namespace lightskin::roomlight {

struct RoomLightOptions {
    /// Every stride-th pixel in x and y is a sample (4: 19200 samples at 640x480). Trade-off: time ~ 1/stride^2.
    int stride = 4;
    /// At most this many samples enter the robust fit (every n-th of those with a segment). Trade-off: the fit's
    /// time is ~ proportional; its noise ~ 1 / sqrt(maxFitSamples) (0.5 % of a coefficient at 2 % pixel noise).
    int maxFitSamples = 20000;
    /// Normal from the 3-D points normalRadius pixels left/right/up/down (central differences), pixels.
    int normalRadius = 3;
    /// Neighbours whose depth differs from the centre by more than this fraction of it break the normal
    /// (a depth edge): the sample is dropped.
    double maxDepthStepFraction = 0.05;
    /// Depth outside [minDepthMetres, maxDepthMetres] is invalid.
    double minDepthMetres = 0.3;
    double maxDepthMetres = 8.0;
    /// An 8-bit channel at or above this code is clipped (its radiance is unknown, the pixel may be an emitter).
    int clippedCode = 250;
    /// Albedo the largest chromaticity segment is assumed to have (all channels). The model's one free scale.
    double referenceAlbedo = 0.5;
    /// Time constant of the exponential filter, seconds: after a step change of the light the estimate has moved
    /// 1 - 1/e of the way after tau (exposure and white-balance changes are followed at once, not filtered).
    double timeConstantSeconds = 0.25;
    /// Frame interval used when the frame has no usable timestamp, seconds.
    double nominalFrameSeconds = 1.0 / 30.0;
    /// Fallback thresholds (FrameProblem).
    int minSamples = 200;
    double darkLevel = 0.01; ///< linear pixel value (0..1) of the median valid sample
    double maxClippedFraction = 0.6;
    /// A fit whose robust relative residual (LightEstimate::residual) is above this is not used (PoorFit). Predicting
    /// black gives 1; the model holds a constant shading per segment, whose residual is CV / sqrt(1 + CV^2) for
    /// pixel values with a coefficient of variation CV within the segment, 0.71 at CV = 1 (values scattered as
    /// widely as their mean: no shading left to fit). A fit above 0.75 explains less than that constant could.
    double maxResidual = 0.75;
    /// Uniform irradiance before the first usable frame, camera units (a grey card of albedo referenceAlbedo
    /// would show referenceAlbedo / pi * neutralIrradiance: 0.18 with the defaults).
    double neutralIrradiance = 0.18 * kPi / 0.5;
    /// Tikhonov weight on the ambient SH bands 1 and 2 relative to the data (keeps a box room's few normals
    /// from trading the free light against the ambient).
    double ambientRidge = 0.05;
    /// A light whose E0 is below this fraction of the mean ambient irradiance is not a dominant light.
    double minDominantRatio = 0.1;
};

/// Irradiance the estimate predicts on a surface at `positionWorld` (metres) with unit `normalWorld`, camera
/// units: the local light and the emitters at their positions (no shadows) plus the ambient SH. A Lambertian
/// surface of albedo rho there shows rho / pi times this.
glm::dvec3 predictIrradiance(const LightEstimate& estimate, const glm::dvec3& positionWorld,
                             const glm::dvec3& normalWorld) noexcept;

class RoomLightEstimator {
public:
    explicit RoomLightEstimator(RoomLightOptions options);
    ~RoomLightEstimator();
    RoomLightEstimator(RoomLightEstimator&&) noexcept;
    RoomLightEstimator& operator=(RoomLightEstimator&&) noexcept;

    /// Estimates from one frame. `frame`: depth registered to colour (DepthRegistration::RegisteredToColour),
    /// colour CV_8UC3 BGR sRGB as RgbdFrame says; `world_T_camera` the colour camera's pose;
    /// `referencePointWorld`: where the virtual objects stand (the SH and the dominant light are for that
    /// point); nullopt = the centroid of this frame's surface samples. Bad frames give a fallback (see
    /// EstimateState), never an exception; an unregistered frame throws lightskin::Error naming the frame.
    /// The reference stays valid until the next call.
    const LightEstimate& estimate(const RgbdFrame& frame, const Pose& world_T_camera,
                                  std::optional<glm::dvec3> referencePointWorld = std::nullopt);

    /// Forgets the history (the next frame starts a new estimate, the free light is searched again).
    void reset();

    const LightEstimate& last() const noexcept;
    const RoomLightOptions& options() const noexcept;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::roomlight
