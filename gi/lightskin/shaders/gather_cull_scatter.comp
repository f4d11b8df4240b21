#version 450 core
#include "gather_cull.glsl"
// Stable VAL culling, pass 3 of 3 (gather_cull.glsl): every kept VAL is copied to its work
// group's offset (pass 2) plus its slot in the group (pass 1): input order is kept.
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Source { VirtualAreaLight source[]; };
layout(std430, binding = 1) readonly buffer Slots { uint slot[]; };
layout(std430, binding = 2) readonly buffer GroupOffsets { uint groupOffset[]; };
layout(std430, binding = 4) writeonly buffer Destination { VirtualAreaLight destination[]; };
uniform uint uCount;
uniform uint uGroupFirst;

void main() {
    const uint group = uGroupFirst + gl_WorkGroupID.x;
    const uint i = group * CULL_GROUP_SIZE + gl_LocalInvocationID.x;
    if (i >= uCount) return;
    const uint s = slot[i];
    if (s == CULL_DROPPED) return;
    destination[groupOffset[group] + s] = source[i];
}
