// Injection of one point into the accumulation buffer (12 uints per voxel: count, emitter count,
// normal sum xyz, radiance sum rgb, albedo sum rgb, unused). Floats are added by compare-and-swap
// loops: GL 4.5 core has no float atomics.
#ifndef LIGHTSKIN_VOLUMES_INJECT_GLSL
#define LIGHTSKIN_VOLUMES_INJECT_GLSL
#include "volumes_common.glsl"

layout(std430, binding = 0) buffer Accumulation { uint accumulation[]; };

void atomicAddFloat(uint i, float value) {
    uint expected = accumulation[i];
    for (;;) {
        const uint found = atomicCompSwap(accumulation[i], expected, floatBitsToUint(uintBitsToFloat(expected) + value));
        if (found == expected) break;
        expected = found;
    }
}

void injectPoint(vec3 position, vec3 normal, vec3 radiance, vec3 albedo, bool emits) {
    const ivec3 v = voxelOf(position);
    if (!insideGrid(v)) return;
    const uint base = 12u * voxelIndex(v);
    atomicAdd(accumulation[base], 1u);
    for (int k = 0; k < 3; ++k) {
        atomicAddFloat(base + 2u + uint(k), normal[k]);
        atomicAddFloat(base + 8u + uint(k), albedo[k]);
    }
    if (!emits) return;
    atomicAdd(accumulation[base + 1u], 1u);
    for (int k = 0; k < 3; ++k) atomicAddFloat(base + 5u + uint(k), radiance[k]);
}
#endif
