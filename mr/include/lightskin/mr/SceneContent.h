#pragma once
// Moving content: the checks a host's change to the scene's objects and lights passes before the pipeline
// applies it, and the animations' state at a frame's time. No GL; the pipeline (FramePipeline) applies the
// result to its renderer and GI.

#include <lightskin/core/RgbdFrame.h>
#include <lightskin/render/Scene.h>

#include <glm/mat4x4.hpp>

#include <cstdint>
#include <limits>
#include <string>

namespace lightskin::mr {

/// Throws lightskin::Error (source `source`, cause "object <i>: ...") unless `world_T_model` is a placement the
/// techniques take: finite, last row 0 0 0 1, its 3x3 part a rotation (or a mirroring) times one uniform scale
/// > 0 (normals and the sparse points' radii assume no shear and no stretch).
void checkPlacement(const glm::mat4& world_T_model, const std::string& source, const std::string& what);
/// Throws unless the albedos are finite in [0, 1] and the exponent finite >= 1.
void checkMaterial(const render::MaterialOverride& material, const std::string& source, const std::string& what);
/// Throws unless position and power are finite, power >= 0 and a spot light's direction finite and non-zero.
void checkLightValues(const render::SceneLight& light, const std::string& source, const std::string& what);

/// The animations' clock: seconds since the first frame it saw, from the colour timestamps, or, for a
/// source without them (NaN), from the frame indices at 30 frames per second.
class AnimationClock {
public:
    double timeOf(const RgbdFrame& frame);

private:
    double firstTimestamp_ = std::numeric_limits<double>::quiet_NaN();
    std::int64_t firstIndex_ = -1;
};

/// Writes every animated object's placement and every animated light's position, direction and power at
/// `timeSeconds` into `scene` (the animations stay; static content is left as it is).
void sampleAnimations(render::Scene& scene, double timeSeconds);

} // namespace lightskin::mr
