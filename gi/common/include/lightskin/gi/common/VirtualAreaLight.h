#pragma once
// A virtual area light (VAL, LightSkin section 3.1): a homogeneous Lambertian disc emitter.
// VALs come from depth pixels of the real scene (ValGenerator) or from reflective shadow maps of
// the virtual content. The VAL set is the common input of every indirect-illumination technique.
//
// Units and frames: world frame, metres; area in m^2 (disc radius r = sqrt(area / pi));
// flux is radiant flux in linear RGB, phi = pi * L_e * area for emitted radiance L_e
// (so phi / area is the radiant exitance M = pi * L_e).

#include <glm/vec3.hpp>

#include <cstdint>

namespace lightskin::gi {

/// GPU layout: std430 / std140-compatible, three vec4 (48 bytes). Keep in sync with
/// gi/common/shaders/virtual_area_light.glsl.
struct VirtualAreaLight {
    glm::vec3 position{0.0f}; ///< disc centre, world metres
    float area = 0.0f;        ///< disc area, m^2 (> 0 for a valid VAL)
    glm::vec3 normal{0.0f, 0.0f, 1.0f}; ///< unit, world; the side that emits
    float reserved0 = 0.0f;
    glm::vec3 flux{0.0f};     ///< linear RGB radiant flux (phi = pi * L_e * area)
    float reserved1 = 0.0f;
};
static_assert(sizeof(VirtualAreaLight) == 48, "VirtualAreaLight must match the GLSL std430 layout");

/// A set of VALs on the GPU: `count` valid, packed VirtualAreaLight records at the start of `buffer`
/// (a GL buffer name usable as SSBO, or as UBO ranges). Not owning: the producer owns the buffer.
///
/// Optional change information (lets a consumer reuse work for static content without reading the
/// VALs back): `generation` != 0 promises that two views with equal buffer, count and generation
/// hold bit-identical VALs (the producer bumps it whenever it rewrites the buffer); 0 = unknown,
/// consumers must assume the set changed. `keys` (a GL buffer of one uint per VAL, < keyCount)
/// names each VAL stably across frames (ValGenerator: the depth pixel it came from), so that a
/// consumer can compare a VAL with its predecessor; 0 = no keys.
struct ValSetView {
    std::uint32_t buffer = 0;
    std::uint32_t count = 0;
    std::uint64_t generation = 0;
    std::uint32_t keys = 0;
    std::uint32_t keyCount = 0;
    /// When keys name pixels of an image (v * keyWidth + u, keyCount = keyWidth * height): its width,
    /// so that a consumer can build the image's quadtree over the VALs (ValTree.h); 0 = not an image.
    std::uint32_t keyWidth = 0;
};

} // namespace lightskin::gi
