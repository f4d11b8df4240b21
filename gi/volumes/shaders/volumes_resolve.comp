#version 450 core
// Per occupied voxel: the means of the injected points (Voxel) and the first exitant radiance (= direct).
#include "volumes_common.glsl"

layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Accumulation { uint accumulation[]; };
layout(std430, binding = 1) writeonly buffer Voxels { Voxel voxels[]; };
layout(std430, binding = 2) writeonly buffer Exitant { vec4 exitant[]; };
layout(std430, binding = 11) readonly buffer OccupiedSlot { uint occupiedSlot[]; };

void main() {
    const uint i = linearIndex();
    if (i >= voxelCount()) return;
    const uint slot = occupiedSlot[i];
    if (slot == 0u) return;
    const uint base = 12u * (slot - 1u);
    const uint count = accumulation[base], emitters = accumulation[base + 1u];
    Voxel voxel = Voxel(vec4(0.0), vec4(0.0), vec4(0.0));
    if (count > 0u) {
        const vec3 normalSum = uintBitsToFloat(uvec3(accumulation[base + 2u], accumulation[base + 3u], accumulation[base + 4u]));
        const vec3 radianceSum = uintBitsToFloat(uvec3(accumulation[base + 5u], accumulation[base + 6u], accumulation[base + 7u]));
        const vec3 albedoSum = uintBitsToFloat(uvec3(accumulation[base + 8u], accumulation[base + 9u], accumulation[base + 10u]));
        const vec3 mean = normalSum / float(count);
        const float len = length(mean);
        // Normals that cancel (|mean| < 1/2): seen from every side (reference: Volume::normal).
        voxel.normalOccupied = vec4(len >= 0.5 ? mean / len : vec3(0.0), 1.0);
        voxel.direct = vec4(emitters > 0u ? radianceSum / float(emitters) : vec3(0.0), 0.0);
        voxel.albedo = vec4(albedoSum / float(count), 0.0);
    }
    voxels[slot - 1u] = voxel;
    exitant[slot - 1u] = voxel.direct;
}
