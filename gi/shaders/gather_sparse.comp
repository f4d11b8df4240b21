#version 450 core
// Gather, compute-shader variant (kept to measure against the fragment passes, as the paper
// did): a work group of 64 sparse points stages 64 VALs at a time in shared memory; each
// dispatch covers at most uValCount VALs (keeps each loop far below llvmpipe's ~65k limit) and
// adds its sums to the targets (image load/store; one thread owns one texel). Same outputs as
// gather_sparse.frag. Variants: GLOSSY, OCCLUSION.
#include "lightskin_math.glsl"
#include "virtual_area_light.glsl"
#include "gather_sparse_points.glsl"

layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Vals { VirtualAreaLight vals[]; };
layout(binding = 0, rgba32f) uniform image2D uOutDiffuse;
layout(binding = 1, rgba32f) uniform image2D uOutOffsetD;
layout(binding = 2, rgba32f) uniform image2D uOutGlossy;
layout(binding = 3, rgba32f) uniform image2D uOutOffsetS;
layout(binding = 4, rgba32f) uniform image2D uOutMoments;
uniform uint uValFirst;
uniform uint uValCount;
uniform vec3 uEye;
uniform float uC;

shared vec4 tile[3 * 64];

void main() {
    const int index = int(gl_GlobalInvocationID.x);
    const bool inRange = index < uPointCount;
    const ivec2 texel = gather_pointTexel(min(index, uPointCount - 1));
    const vec4 positionK = texelFetch(uPointPosition, texel, 0);
    const vec3 x = positionK.xyz;
    const vec3 n = texelFetch(uPointNormal, texel, 0).xyz;
    const float k = positionK.w;
    const float ck = uC * (k + 1.0);
    const vec3 toEye = ls_toEye(x, uEye);
    vec4 diffuse = vec4(0.0), offsetD = vec4(0.0), glossy = vec4(0.0), offsetS = vec4(0.0), moments = vec4(0.0);
    const uint local = gl_LocalInvocationID.x;
    for (uint base = 0u; base < uValCount; base += 64u) {
        const uint j = base + local;
        if (j < uValCount) {
            const VirtualAreaLight val = vals[uValFirst + j];
            tile[3u * local] = val.positionArea;
            tile[3u * local + 1u] = val.normal;
            tile[3u * local + 2u] = val.flux;
        }
        barrier();
        const uint count = min(64u, uValCount - base);
        for (uint t = 0u; t < count; ++t) {
            const vec4 a = tile[3u * t];
            const vec4 b = tile[3u * t + 1u];
            const vec4 f = tile[3u * t + 2u];
            const GatherSample s = ls_gatherSample(x, n, a.xyz, b.xyz, a.w, f.rgb, toEye, k, ck, 0.0);
            diffuse += vec4(s.irradiance, s.r2 * s.weightD);
            offsetD += vec4(s.offset * s.weightD, s.weightD);
#ifdef GLOSSY
            glossy += vec4(s.glossy, s.r2 * s.weightS);
            offsetS += vec4(s.offset * s.weightS, s.weightS);
#endif
#ifdef OCCLUSION
            moments.xyz += s.offset * s.offset * s.weightD;
#ifdef GLOSSY
            moments.w += dot(s.offset, s.offset) * s.weightS;
#endif
#endif
        }
        barrier();
    }
    if (!inRange) return;
    imageStore(uOutDiffuse, texel, imageLoad(uOutDiffuse, texel) + diffuse);
    imageStore(uOutOffsetD, texel, imageLoad(uOutOffsetD, texel) + offsetD);
    imageStore(uOutGlossy, texel, imageLoad(uOutGlossy, texel) + glossy);
    imageStore(uOutOffsetS, texel, imageLoad(uOutOffsetS, texel) + offsetS);
    imageStore(uOutMoments, texel, imageLoad(uOutMoments, texel) + moments);
}
