// Eq. 4/5 of imperfect volumes; include after declaring the readonly buffers incoming[] (RgbSh),
// occupiedSlot[] and activeSlot[] of volumes_common.glsl.
#ifndef LIGHTSKIN_VOLUMES_IRRADIANCE_GLSL
#define LIGHTSKIN_VOLUMES_IRRADIANCE_GLSL
#include "volumes_common.glsl"

// Eq. 4/5: p moved s/2 along n; the eight nearest voxel centres weighted by max(0, cos); occupied
// voxels only when no free one has weight (their SH is biased by self-intersection). Returns E
// per channel (W/m^2; pi * AO for visibility), clamped at 0 (L1 ringing).
vec3 reconstructIrradiance(vec3 p, vec3 n) {
    const vec3 shifted = p + 0.5 * uVoxelSize * n;
    const ivec3 base = ivec3(floor((shifted - uGridOrigin) / uVoxelSize - 0.5));
    RgbSh freeSum = RgbSh(vec4(0.0), vec4(0.0), vec4(0.0));
    RgbSh occupiedSum = RgbSh(vec4(0.0), vec4(0.0), vec4(0.0));
    float freeWeight = 0.0, occupiedWeight = 0.0;
    for (int corner = 0; corner < 8; ++corner) {
        const ivec3 v = base + ivec3(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
        if (!insideGrid(v)) continue;
        const vec3 toCentre = voxelCentre(v) - shifted;
        const float len = length(toCentre);
        const float w = len > 1e-6 * uVoxelSize ? max(0.0, dot(n, toCentre) / len) : 1.0;
        if (w <= 0.0) continue;
        const uint i = voxelIndex(v);
        // Every voxel read here was marked (volumes_mark.comp); without a slot (beyond the capacity) it
        // counts as not marched: 0.
        const uint slot = activeSlot[i];
        const RgbSh sh = slot != 0u ? incoming[slot - 1u] : RgbSh(vec4(0.0), vec4(0.0), vec4(0.0));
        if (occupiedSlot[i] != 0u) {
            occupiedWeight += w;
            occupiedSum.r += w * sh.r;
            occupiedSum.g += w * sh.g;
            occupiedSum.b += w * sh.b;
        } else {
            freeWeight += w;
            freeSum.r += w * sh.r;
            freeSum.g += w * sh.g;
            freeSum.b += w * sh.b;
        }
    }
    const bool useFree = freeWeight > 0.0;
    const float total = useFree ? freeWeight : occupiedWeight;
    if (total <= 0.0) return vec3(0.0);
    const RgbSh sum = useFree ? freeSum : occupiedSum;
    const vec4 lobe = shCosineLobe(n);
    return max(vec3(dot(sum.r, lobe), dot(sum.g, lobe), dot(sum.b, lobe)) / total, vec3(0.0));
}
#endif
