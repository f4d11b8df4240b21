#pragma once
// Removes the depth VALs whose space the virtual content now occupies: a real surface
// enclosed by or pressed against a virtual object sends no light to the visible world, and as a VAL
// within millimetres of the object's receivers it is where the disc model is least accurate. Such
// VALs get area 0 (every consumer skips them). The test and its Kinect-noise margin (metres along the
// optical axis): docs/LIGHTSKIN.md, "VALs inside virtual content".
//
// The test uses the VAL's key (ValGenerator::pixelIndexBuffer(): its depth pixel), so it needs depth
// registered to the colour camera the view is rendered with, at the same resolution.

#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gi/common/VirtualAreaLight.h>
#include <lightskin/gl/Objects.h>

#include <glm/mat4x4.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace lightskin::gi {

class ValOccupancyCull {
public:
    ValOccupancyCull() = default;
    /// Compiles the passes and sizes the depth-range target for width x height pixels (the depth
    /// map's size, registered to the camera). Needs a current GL 4.5 context until destruction.
    /// Throws lightskin::Error on a bad size.
    static ValOccupancyCull create(int width, int height);

    /// Renders the instances' depth range per pixel with `clip_T_world` (the camera's projection *
    /// view, as the G-buffer) and `camera_T_world` (for depths along the optical axis), then sets
    /// area = 0 in `vals` for every culled VAL (see above). `vals.keys` must be the depth pixel index
    /// (v * width + u) of each VAL. Returns nothing (no read-back); culledCount() reads the count.
    /// The set is changed in place: a producer that hands out the same buffer again without
    /// regenerating it (ValGeneratorSettings::skipUnchangedInput) keeps this cull, which stays right
    /// while the virtual content has not moved (scene objects are fixed in the pipeline); culling a
    /// culled set again changes nothing.
    /// GL state changed: framebuffer binding 0, program, SSBO bindings 0-2, texture unit 0, viewport.
    void apply(const ValSetView& vals, std::span<const MeshInstance> instances, const glm::mat4& clip_T_world,
               const glm::mat4& camera_T_world);

    /// The same cull for VALs on the CPU (gi::CpuValGenerator's, for the CPU backend): renders the
    /// depth range on GL, reads it back (8 bytes per pixel) and sets area = 0 in `vals` with the
    /// cull pass's float operations. keys[i]: the depth pixel of vals[i]. Returns the count culled.
    std::uint32_t applyOnCpu(std::span<VirtualAreaLight> vals, std::span<const std::uint32_t> keys,
                             std::span<const MeshInstance> instances, const glm::mat4& clip_T_world,
                             const glm::mat4& camera_T_world);
    /// VALs culled by the last apply() (reads one uint back: a GPU sync; tests and logging).
    std::uint32_t culledCount() const;

private:
    int width_ = 0, height_ = 0;
    gl::Program range_, cull_;
    gl::Texture rangeTexture_;
    gl::Framebuffer framebuffer_;
    gl::Buffer counter_;
    std::vector<float> rangeOnCpu_; // applyOnCpu(): the range target read back, sized on first use

    void renderRange(std::span<const MeshInstance> instances, const glm::mat4& clip_T_world,
                     const glm::mat4& camera_T_world);
};

} // namespace lightskin::gi
