#version 450 core
#include "virtual_area_light.glsl"
// Static content, tolerance mode: scatters a keyed VAL set into a dense array indexed by key (the
// array is cleared to area 0 = "no VAL" before), so that the bound pass can pair every VAL with
// the one of the same key at the last full computation. Keys >= uKeyCount are ignored (their VALs
// then never count as unchanged: the bound pass sees them as missing on both sides, see there).
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Source { VirtualAreaLight source[]; };
layout(std430, binding = 1) readonly buffer Keys { uint keys[]; };
layout(std430, binding = 2) writeonly buffer Dense { VirtualAreaLight dense[]; };
layout(std430, binding = 3) buffer Check { float bound; uint referenceBits; uint badKeys; uint referenceBadKeys; };
uniform uint uCount;
uniform uint uKeyCount;

void main() {
    const uint i = gl_GlobalInvocationID.x;
    if (i >= uCount) return;
    const uint key = keys[i];
    if (key < uKeyCount) dense[key] = source[i];
    else atomicAdd(badKeys, 1u);
}
