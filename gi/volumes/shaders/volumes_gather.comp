#version 450 core
// Section 3.3, eq. 3: per active voxel, rays uRayBegin..uRayEnd-1 (one pass of a chunked loop:
// llvmpipe ends a loop after ~65,000 iterations) from the voxel centre, sampled at sqrt(3)/2 s +
// k s until an occupied voxel or the border; radiance seen from the front of the hit voxel (all
// sides where its normals cancel), or visibility (VOLUMES_VISIBILITY: 1 unless blocked within
// uMaxDistance). The SH sums accumulate over passes; the last one scales by 4 pi / N.
#include "volumes_common.glsl"

layout(local_size_x = 64) in;
layout(std430, binding = 1) readonly buffer Voxels { Voxel voxels[]; };
layout(std430, binding = 2) readonly buffer Exitant { vec4 exitant[]; };
layout(std430, binding = 3) buffer Incoming { RgbSh incoming[]; };
layout(std430, binding = 4) readonly buffer Directions { vec4 directions[]; };
layout(std430, binding = 5) readonly buffer ActiveSlot { uint activeSlot[]; };
layout(std430, binding = 11) readonly buffer OccupiedSlot { uint occupiedSlot[]; };
layout(location = 3) uniform uint uRayBegin;
layout(location = 4) uniform uint uRayEnd;
layout(location = 5) uniform uint uRayCount;
layout(location = 6) uniform int uMaxSteps;     // enough steps to cross the grid
layout(location = 7) uniform float uMaxDistance; // metres (AO range; huge for radiance)
// Temporal mitigation (ImperfectVolumesSettings::jitter / temporalBlend): ray origins moved by this
// sub-voxel offset (voxel units, per frame); on the last chunk of the last pass, the result blended
// with the previous frame's where that voxel was marched then too (its slot then: historySlot).
layout(location = 8) uniform vec3 uOriginOffset;
layout(location = 9) uniform float uHistoryWeight; // 0: no blending
layout(std430, binding = 9) readonly buffer History { RgbSh history[]; };
layout(std430, binding = 10) readonly buffer HistorySlot { uint historySlot[]; };

void main() {
    const uint i = linearIndex();
    if (i >= voxelCount()) return;
    const uint slot = activeSlot[i];
    if (slot == 0u) return;
    const vec3 centre = voxelCentre(voxelFromIndex(i)) + uOriginOffset * uVoxelSize;
    RgbSh sum = uRayBegin == 0u ? RgbSh(vec4(0.0), vec4(0.0), vec4(0.0)) : incoming[slot - 1u];
    for (uint r = uRayBegin; r < uRayEnd; ++r) {
        const vec3 d = directions[r].xyz;
        vec3 radiance = vec3(0.0);
        bool hit = false;
        float t = 0.86602540378 * uVoxelSize;
        for (int k = 0; k < uMaxSteps && t <= uMaxDistance; ++k, t += uVoxelSize) {
            const ivec3 v = voxelOf(centre + t * d);
            if (!insideGrid(v)) break;
            const uint occupied = occupiedSlot[voxelIndex(v)];
            if (occupied == 0u) continue;
            const vec4 no = voxels[occupied - 1u].normalOccupied;
            if (no.w <= 0.0) continue; // allocated but no point landed (float differences between the passes)
            hit = true;
            if (dot(d, no.xyz) < 0.0 || dot(no.xyz, no.xyz) == 0.0) radiance = exitant[occupied - 1u].rgb;
            break;
        }
#ifdef VOLUMES_VISIBILITY
        radiance = vec3(hit ? 0.0 : 1.0);
#endif
        const vec4 y = shBasis(d);
        sum.r += radiance.r * y;
        sum.g += radiance.g * y;
        sum.b += radiance.b * y;
    }
    if (uRayEnd == uRayCount) {
        const float weight = 4.0 * kPi / float(uRayCount);
        sum.r *= weight;
        sum.g *= weight;
        sum.b *= weight;
        if (uHistoryWeight > 0.0 && historySlot[i] != 0u) {
            const RgbSh previous = history[historySlot[i] - 1u];
            sum.r = mix(sum.r, previous.r, uHistoryWeight);
            sum.g = mix(sum.g, previous.g, uHistoryWeight);
            sum.b = mix(sum.b, previous.b, uHistoryWeight);
        }
    }
    incoming[slot - 1u] = sum;
}
