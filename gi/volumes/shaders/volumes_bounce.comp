#version 450 core
// Between passes (multiple bounces, section 3.3): each occupied voxel re-emits its direct radiance
// plus albedo / pi * E, E reconstructed at its centre along its normal from the last pass.
#include "volumes_common.glsl"

layout(local_size_x = 64) in;
layout(std430, binding = 1) readonly buffer Voxels { Voxel voxels[]; };
layout(std430, binding = 2) writeonly buffer Exitant { vec4 exitant[]; };
layout(std430, binding = 3) readonly buffer Incoming { RgbSh incoming[]; };
layout(std430, binding = 5) readonly buffer ActiveSlot { uint activeSlot[]; };
layout(std430, binding = 11) readonly buffer OccupiedSlot { uint occupiedSlot[]; };
#include "volumes_irradiance.glsl"

void main() {
    const uint i = linearIndex();
    if (i >= voxelCount()) return;
    const uint slot = occupiedSlot[i];
    if (slot == 0u) return;
    const Voxel voxel = voxels[slot - 1u];
    vec3 radiance = voxel.direct.rgb;
    if (voxel.normalOccupied.w > 0.0 && dot(voxel.normalOccupied.xyz, voxel.normalOccupied.xyz) > 0.0)
        radiance += voxel.albedo.rgb / kPi * reconstructIrradiance(voxelCentre(voxelFromIndex(i)), voxel.normalOccupied.xyz);
    exitant[slot - 1u] = vec4(radiance, 0.0);
}
