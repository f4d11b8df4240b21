#version 450 core
// Gather, compute-shader variant (kept to measure against the fragment passes, as the paper
// did): a work group of 64 sparse points stages 64 VALs at a time in shared memory; each
// dispatch covers at most uValCount VALs (keeps each loop far below llvmpipe's ~65k limit) and
// continues the running sums in the targets (image load/store; one thread owns one texel) in the
// fixed 16-VAL blocks of gather_sum_block.glsl (uValFirst is a multiple of 64): the same sums as
// gather_sparse.frag, for any dispatch size. Variants: GLOSSY, OCCLUSION.
#include "lightskin_math.glsl"
#include "virtual_area_light.glsl"
#include "gather_sparse_points.glsl"
#include "gather_sum_block.glsl"

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
    GatherSums running = gather_zeroSums();
    if (inRange) {
        running.diffuse = imageLoad(uOutDiffuse, texel);
        running.offsetD = imageLoad(uOutOffsetD, texel);
        running.glossy = imageLoad(uOutGlossy, texel);
        running.offsetS = imageLoad(uOutOffsetS, texel);
        running.moments = imageLoad(uOutMoments, texel);
    }
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
        for (uint first = 0u; first < count; first += uint(kSumBlock)) {
            GatherSums block = gather_zeroSums();
            const uint end = min(first + uint(kSumBlock), count);
            for (uint t = first; t < end; ++t) {
                const vec4 a = tile[3u * t];
                const vec4 b = tile[3u * t + 1u];
                const vec4 f = tile[3u * t + 2u];
                block = gather_addSample(block, ls_gatherSample(x, n, a.xyz, b.xyz, a.w, f.rgb, toEye, k, ck, 0.0, LS_NEAR_FIELD != 0));
            }
            running = gather_addBlock(running, block);
        }
        barrier();
    }
    if (!inRange) return;
    imageStore(uOutDiffuse, texel, running.diffuse);
    imageStore(uOutOffsetD, texel, running.offsetD);
    imageStore(uOutGlossy, texel, running.glossy);
    imageStore(uOutOffsetS, texel, running.offsetS);
    imageStore(uOutMoments, texel, running.moments);
}
