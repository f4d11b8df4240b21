// Adaptive mode, VAL culling (LightSkinIllumination.cpp): the predicate and the layout shared by the
// three passes of the order-preserving (stable) compaction
//   1. gather_cull_count.comp: per VAL its slot among the kept VALs of its work group (shared-
//      memory scan), per work group its kept count;
//   2. gather_cull_scan.comp: one work group turns the work-group counts into offsets (exclusive
//      scan) and writes the total kept count;
//   3. gather_cull_scatter.comp: every kept VAL goes to its work group's offset + its slot.
// Kept VALs stay in their input order, so the gather sums (fixed 16-VAL blocks, gather_sum_block.glsl)
// and the image are bitwise reproducible. The predicate is evaluated once (pass 1); the scatter
// only reads its result.
#ifndef LIGHTSKIN_GATHER_CULL_GLSL
#define LIGHTSKIN_GATHER_CULL_GLSL

#include "virtual_area_light.glsl"

#define CULL_GROUP_SIZE 256u
#define CULL_DROPPED 0xffffffffu

/// Whether a VAL can reach a receiver. Dropped: invalid (area <= 0 or NaN), receivers' bounding
/// sphere (centre xyz, radius w; world metres) wholly behind the VAL's plane (exactly zero
/// contribution), and an irradiance upper bound below `cutoff` (W/m^2).
bool cullKeeps(VirtualAreaLight val, vec4 receiverSphere, float cutoff) {
    const vec4 a = val.positionArea;
    const vec4 b = val.normal;
    const vec4 f = val.flux;
    if (!(a.w > 0.0)) return false;
    const vec3 toCentre = receiverSphere.xyz - a.xyz;
    if (dot(b.xyz, toCentre) < -receiverSphere.w) return false; // sphere behind the emitting side
    const float dMin = max(length(toCentre) - receiverSphere.w, 0.0);
    const float r2 = a.w / 3.14159265;
    // >= M w cos; within 4 r (guard G12 of lightskin_math.glsl: the VAL as an area) >= M F with F <= 1
    const float bound = max(max(f.r, f.g), f.b) / (3.14159265 * (dMin * dMin < 16.0 * r2 ? r2 : r2 + dMin * dMin));
    return !(bound < cutoff);
}

#endif
