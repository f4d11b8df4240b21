#pragma once
// The depth image's VAL quadtree built on the GPU, in compute passes right after the VAL
// generation (gi/lightskin/shaders/val_tree_build.comp): no read-back of the VALs and no upload of the nodes.
// The same tree as the CPU builder buildValQuadtreeInto (ValTree.h: same levels, same clusters, same
// children order); the statistics are combined in float, the cone angle rounded outward so that the
// error bound of the gather with a cut (val_tree_math.glsl) still holds for every member VAL. Node
// numbering differs from the CPU builder's (the shader's file comment): node 0 is the root, leaves
// and inner nodes sit in 2 count + 1 slots, of which 2 n - 1 are used for n valid VALs.
// Units and frames as VirtualAreaLight (world metres, m^2, linear RGB W; angles in radians).

#include <lightskin/gi/common/VirtualAreaLight.h>
#include <lightskin/gi/lightskin/ValTree.h>
#include <lightskin/gl/Objects.h>

#include <cstdint>
#include <vector>

namespace lightskin::gi {

class GpuValQuadtree {
public:
    GpuValQuadtree() = default;
    /// Compiles the passes. Needs a current GL 4.5 context until destruction (owns GL buffers).
    static GpuValQuadtree create();

    /// Builds the quadtree of `vals` (keys and keyWidth required: one uint pixel key v * keyWidth + u
    /// per VAL in a keyWidth x (keyCount / keyWidth) image, as ValGenerator's) into nodeBuffer().
    /// Invalid VALs (area <= 0 or NaN) are left out. Reads 16 bytes back (root, VAL count, key
    /// errors), i.e. waits for the passes. Returns the nodes in use, 2 n - 1 for n valid VALs (0: empty).
    /// Throws Error("VAL keys", ...) naming a VAL whose key lies outside the image or shares a pixel.
    /// Buffers grow (logged) with the VAL count and image size and are reused: no allocation once grown.
    /// GL state changed: program, SSBO bindings 0-5.
    std::uint32_t build(const ValSetView& vals);

    /// The nodes (std430 ValCluster, 112 bytes; node 0 = the root) of the last build(); valid until
    /// the next build() or destruction. Owned by this object.
    std::uint32_t nodeBuffer() const noexcept { return nodes_.id(); }
    /// Node slots of the last build() (2 count + 1; children indices stay below it).
    std::uint32_t nodeSlots() const noexcept { return slots_; }
    /// For tests: reads the nodeSlots() slots back (a GPU sync; unused slots hold stale data).
    void readNodes(std::vector<ValCluster>& out) const;

private:
    gl::Program leaves_, level_, root_;
    gl::Buffer nodes_, cells_[2], info_;
    std::uint32_t nodeCapacity_ = 0, cellCapacity_[2] = {0, 0};
    std::uint32_t slots_ = 0;
};

} // namespace lightskin::gi
