#pragma once
// How well an estimate predicts real pixels it was not fitted to: a random fraction of the sample pixels is held
// out (their depth hidden from the estimator), the rest estimates the light, and the held-out pixels' observed
// radiance is compared with the shading the estimate predicts there (predictIrradiance), against an ambient-only
// baseline (the same shading everywhere). Each chromaticity segment (the estimator's albedo model) gets its own
// least-squares scale per channel in both predictions, fitted on the held-out pixels: the comparison is of the
// shading's shape, which is what the estimate predicts on real data whose albedos are unknown.
// A validation tool (tests, bench), not for the per-frame path: it allocates.

#include <lightskin/core/Pose.h>
#include <lightskin/core/RgbdFrame.h>
#include <lightskin/roomlight/LightEstimate.h>
#include <lightskin/roomlight/RoomLightEstimator.h>

#include <cstdint>

namespace lightskin::roomlight {

struct HoldOutResult {
    LightEstimate estimate;            ///< fitted on the kept pixels
    int heldOutSamples = 0;            ///< held-out samples evaluated (valid depth and normal, not clipped, not dark)
    int segments = 0;                  ///< chromaticity segments among them
    double estimateRelativeRmse = 0.0; ///< sqrt(sum (observed - predicted)^2 / sum observed^2), all channels
    double ambientOnlyRelativeRmse = 0.0;
};

/// `holdOutFraction` in (0, 1): the share of sample pixels held out, chosen by a hash of the pixel and `seed`.
HoldOutResult evaluateHoldOut(const RgbdFrame& frame, const Pose& world_T_camera, const RoomLightOptions& options,
                              double holdOutFraction = 0.2, std::uint32_t seed = 1);

} // namespace lightskin::roomlight
