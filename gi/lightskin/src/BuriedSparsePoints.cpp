#include "LightSkinMath.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/lightskin/BuriedSparsePoints.h>

#include <glm/mat4x4.hpp>
#include <glm/vec4.hpp>

#include <cmath>

namespace lightskin::gi {

namespace m = refmath;

bool isBuriedUnderRealSurface(const glm::dvec3& world, const RealDepthView& depth) noexcept {
    if (depth.data == nullptr || depth.width <= 0 || depth.height <= 0) return false;
    const glm::dvec3 pc(glm::dmat4(depth.camera_T_world) * glm::dvec4(world, 1.0));
    if (!(pc.z > 0.0)) return false; // behind the camera (or NaN): not in the image
    const glm::dvec4 k(depth.intrinsics);
    const glm::dvec2 uv = m::ls_projectToPixel(pc, k.x, k.y, k.z, k.w);
    // Nearest pixel centre; written so that NaN fails the range test.
    const double u = std::floor(uv.x + 0.5), v = std::floor(uv.y + 0.5);
    if (!(u >= 0.0 && v >= 0.0 && u < double(depth.width) && v < double(depth.height))) return false;
    const std::size_t index = std::size_t(v) * std::size_t(depth.width) + std::size_t(u);
    return m::ls_isBuried(pc.z, double(depth.data[index]));
}

void markBuriedInto(std::span<const glm::dvec3> worldPositions, const RealDepthView& depth,
                    std::span<std::uint8_t> out) {
    LIGHTSKIN_ASSERT(worldPositions.size() == out.size(), "lightskin::gi::markBuriedInto(): one flag per position");
    for (std::size_t i = 0; i < worldPositions.size(); ++i)
        out[i] = isBuriedUnderRealSurface(worldPositions[i], depth) ? 1 : 0;
}

} // namespace lightskin::gi
