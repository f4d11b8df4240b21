#pragma once
// Guard G11 of gi/lightskin/shaders/lightskin_math.glsl on the CPU: which points lie under the real
// surface, i.e. more than the depth noise (3 sigma of the Kinect v1 model) behind the registered depth
// of the pixel they project to. Points behind the camera, outside the image or on a hole (depth <= 0
// or NaN) are not buried. Double precision, with the shaders' formulas (the same source file); the
// GL technique evaluates them in gather_interpolate.comp.

#include <lightskin/gi/common/IndirectIllumination.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <span>

namespace lightskin::gi {

/// Whether the world point (metres) lies under the real surface of `depth` (its CPU map; false when
/// depth.data is null).
bool isBuriedUnderRealSurface(const glm::dvec3& world, const RealDepthView& depth) noexcept;

/// out[i] = 1 if worldPositions[i] is buried, else 0; sizes must match. Does not allocate.
void markBuriedInto(std::span<const glm::dvec3> worldPositions, const RealDepthView& depth,
                    std::span<std::uint8_t> out);

} // namespace lightskin::gi
