#version 450 core
// Sparse storage: every flagged voxel of a slot map (value != 0) gets the next compact slot (the map
// then holds 1 + its index); beyond uCapacity it gets none (0) and is counted all the same, so the
// counter tells how many were requested. VOLUMES_CLEAR_ACCUMULATION: also zero the slot's sums.
#include "volumes_common.glsl"

layout(local_size_x = 64) in;
layout(std430, binding = 5) buffer SlotMap { uint slotMap[]; };
layout(std430, binding = 12) buffer Counters { uint counters[]; };
layout(location = 3) uniform uint uCapacity;
layout(location = 4) uniform uint uCounter; // 0: occupied voxels, 1: ray-marched voxels
#ifdef VOLUMES_CLEAR_ACCUMULATION
layout(std430, binding = 0) writeonly buffer Accumulation { uint accumulation[]; };
#endif

void main() {
    const uint i = linearIndex();
    if (i >= voxelCount() || slotMap[i] == 0u) return;
    const uint s = atomicAdd(counters[uCounter], 1u);
    slotMap[i] = s < uCapacity ? s + 1u : 0u;
#ifdef VOLUMES_CLEAR_ACCUMULATION
    if (s < uCapacity)
        for (uint k = 0u; k < 12u; ++k) accumulation[12u * s + k] = 0u;
#endif
}
