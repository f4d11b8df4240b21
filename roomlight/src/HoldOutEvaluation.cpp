#include "SurfaceSamples.h"

#include <lightskin/roomlight/HoldOutEvaluation.h>

#include <cmath>
#include <vector>

namespace lightskin::roomlight {
namespace {

// A 32-bit integer hash (lowbias32, Chris Wellons) of the pixel index: a reproducible, well-mixed choice.
std::uint32_t hashPixel(std::uint32_t x) {
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
}

struct SegmentSums {
    glm::dvec3 observedTimesPredicted{0.0}, predictedSquared{0.0}, observed{0.0};
    int count = 0;
};

} // namespace

HoldOutResult evaluateHoldOut(const RgbdFrame& frame, const Pose& world_T_camera, const RoomLightOptions& options,
                              double holdOutFraction, std::uint32_t seed) {
    SurfaceSamples all;
    extractSurfaceSamples(frame, world_T_camera, options, all);
    std::vector<int> binCounts;
    HoldOutResult result;
    result.segments = segmentSamples(all, binCounts);
    const auto threshold = static_cast<std::uint32_t>(holdOutFraction * 4294967295.0);
    std::vector<bool> heldOut(all.size(), false);
    RgbdFrame kept = frame.clone();
    for (std::size_t i = 0; i < all.size(); ++i) {
        if ((hashPixel(static_cast<std::uint32_t>(all.pixelIndex[i]) ^ seed * 0x9e3779b9U)) >= threshold) continue;
        heldOut[i] = true;
        // Only the sample's own pixel: the normals of the kept samples read depth 3 pixels away, never another
        // sample's centre (the sample grid is 4 pixels), so they are unchanged.
        kept.depth.at<std::uint16_t>(all.pixelIndex[i] / frame.depth.cols, all.pixelIndex[i] % frame.depth.cols) = 0;
    }
    RoomLightEstimator estimator(options);
    result.estimate = estimator.estimate(kept, world_T_camera);

    std::vector<SegmentSums> sums(static_cast<std::size_t>(result.segments));
    std::vector<glm::dvec3> predicted(all.size(), glm::dvec3(0.0));
    for (std::size_t i = 0; i < all.size(); ++i) {
        if (!heldOut[i] || all.segment[i] < 0) continue;
        predicted[i] = predictIrradiance(result.estimate, all.positionWorld[i], all.normalWorld[i]);
        SegmentSums& segment = sums[static_cast<std::size_t>(all.segment[i])];
        segment.observedTimesPredicted += all.radiance[i] * predicted[i];
        segment.predictedSquared += predicted[i] * predicted[i];
        segment.observed += all.radiance[i];
        ++segment.count;
    }
    double estimateSquares = 0.0, ambientSquares = 0.0, observedSquares = 0.0;
    for (std::size_t i = 0; i < all.size(); ++i) {
        if (!heldOut[i] || all.segment[i] < 0) continue;
        const SegmentSums& segment = sums[static_cast<std::size_t>(all.segment[i])];
        const glm::dvec3 scale = segment.observedTimesPredicted / glm::max(segment.predictedSquared, glm::dvec3(1e-30));
        const glm::dvec3 estimateError = all.radiance[i] - scale * predicted[i];
        const glm::dvec3 ambientError = all.radiance[i] - segment.observed / static_cast<double>(segment.count);
        estimateSquares += glm::dot(estimateError, estimateError);
        ambientSquares += glm::dot(ambientError, ambientError);
        observedSquares += glm::dot(all.radiance[i], all.radiance[i]);
        ++result.heldOutSamples;
    }
    if (observedSquares > 0.0) {
        result.estimateRelativeRmse = std::sqrt(estimateSquares / observedSquares);
        result.ambientOnlyRelativeRmse = std::sqrt(ambientSquares / observedSquares);
    }
    return result;
}

} // namespace lightskin::roomlight
