// Injection of one point. VOLUMES_MARK_OCCUPANCY: only flag its voxel in occupiedSlot (first pass);
// else add it to its voxel's slot of the accumulation buffer (12 uints per occupied voxel: count,
// emitter count, normal sum xyz, radiance sum rgb, albedo sum rgb, unused). Floats are added by
// compare-and-swap loops: GL 4.5 core has no float atomics.
#ifndef LIGHTSKIN_VOLUMES_INJECT_GLSL
#define LIGHTSKIN_VOLUMES_INJECT_GLSL
#include "volumes_common.glsl"

#ifdef VOLUMES_MARK_OCCUPANCY
layout(std430, binding = 11) writeonly buffer OccupiedSlot { uint occupiedSlot[]; };

void injectPoint(vec3 position, vec3 normal, vec3 radiance, vec3 albedo, bool emits) {
    const ivec3 v = voxelOf(position);
    if (insideGrid(v)) occupiedSlot[voxelIndex(v)] = 1u;
}
#else
layout(std430, binding = 0) buffer Accumulation { uint accumulation[]; };
layout(std430, binding = 11) readonly buffer OccupiedSlot { uint occupiedSlot[]; };

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
    const uint slot = occupiedSlot[voxelIndex(v)];
    if (slot == 0u) return; // beyond the capacity (counted by the allocation)
    const uint base = 12u * (slot - 1u);
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
#endif
