#version 450 core
// Marks the voxels a reconstruction will read (the eight around p + s/2 n): per covered G-buffer
// pixel (VOLUMES_MARK_PIXELS) or per occupied voxel with a normal (bounces). Only those are ray-marched.
// A back-face pixel (normal w = 1) reads none: volumes_reconstruct.comp writes 0 there.
#include "volumes_common.glsl"

#ifdef VOLUMES_MARK_PIXELS
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0) uniform sampler2D uPosition; // xyz world, w = 1 where covered
layout(binding = 1) uniform sampler2D uNormal;
layout(location = 3) uniform ivec2 uSize;
#else
layout(local_size_x = 64) in;
layout(std430, binding = 1) readonly buffer Voxels { Voxel voxels[]; };
layout(std430, binding = 11) readonly buffer OccupiedSlot { uint occupiedSlot[]; };
#endif
layout(std430, binding = 5) buffer ActiveSlot { uint activeSlot[]; }; // flagged here, allocated after

void markAround(vec3 p, vec3 n) {
    const vec3 shifted = p + 0.5 * uVoxelSize * n;
    const ivec3 base = ivec3(floor((shifted - uGridOrigin) / uVoxelSize - 0.5));
    for (int corner = 0; corner < 8; ++corner) {
        const ivec3 v = base + ivec3(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
        if (insideGrid(v)) activeSlot[voxelIndex(v)] = 1u;
    }
}

void main() {
#ifdef VOLUMES_MARK_PIXELS
    const ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, uSize))) return;
    const vec4 position = texelFetch(uPosition, pixel, 0);
    if (position.w <= 0.0) return;
    const vec4 normal = texelFetch(uNormal, pixel, 0);
    const vec3 n = normal.xyz;
    if (normal.w > 0.5 || dot(n, n) <= 0.0) return;
    markAround(position.xyz, normalize(n));
#else
    const uint i = linearIndex();
    if (i >= voxelCount() || occupiedSlot[i] == 0u) return;
    const vec4 no = voxels[occupiedSlot[i] - 1u].normalOccupied;
    if (no.w > 0.0 && dot(no.xyz, no.xyz) > 0.0) markAround(voxelCentre(voxelFromIndex(i)), no.xyz);
#endif
}
