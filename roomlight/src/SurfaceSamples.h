#pragma once
// The real surfaces of one frame as samples: every stride-th pixel with valid depth and a normal, its world
// position, world normal and linear radiance. Internal to roomlight.

#include <lightskin/core/Pose.h>
#include <lightskin/core/RgbdFrame.h>
#include <lightskin/roomlight/RoomLightEstimator.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace lightskin::roomlight {

struct SurfaceSamples {
    std::vector<glm::dvec3> positionWorld;     ///< metres
    std::vector<glm::dvec3> normalWorld;       ///< unit, facing the camera
    std::vector<glm::dvec3> radiance;          ///< linear RGB in [0, 1] (sRGB decoded); clipped channels read 1
    std::vector<std::uint8_t> clipped;         ///< 1 when a channel is at or above RoomLightOptions::clippedCode
    std::vector<double> footprintSquareMetres; ///< surface area the sample stands for (stride^2 pixels)
    std::vector<int> segment;                  ///< chromaticity segment (segmentSamples), -1 = not used for the fit
    std::vector<int> pixelIndex;               ///< v * imageWidth + u of the sample's pixel
    int imageWidth = 0;                        ///< pixels

    std::size_t size() const noexcept { return positionWorld.size(); }
    void clear() noexcept;
    void reserve(std::size_t count);
};

/// Fills `out` from a registered frame. Reuses out's storage (no allocation once reserved for the frame size).
void extractSurfaceSamples(const RgbdFrame& frame, const Pose& world_T_camera, const RoomLightOptions& options,
                           SurfaceSamples& out);

/// Albedo model: segments of similar chromaticity (r, g) = (R, G) / (R + G + B), in bins of 1/16; the most
/// populated bin and its 8 neighbours form a segment, then the next, up to kMaxSegments segments that hold at
/// least 3 % of the usable samples each. Clipped and very dark samples (chromaticity unreliable) get -1.
/// Returns the number of segments; segment 0 is the largest (the reference segment).
inline constexpr int kMaxSegments = 6;
int segmentSamples(SurfaceSamples& samples, std::vector<int>& binCounts);

} // namespace lightskin::roomlight
