#version 450 core
// Gather (eq. 3-5, 7 without the eps_l terms, see gather_val_sums.comp; the paper's Listing 1): one fragment per sparse point, K_CACHE VALs per
// pass from the uniform block. Each pass continues the running sums of the previous passes (read
// from the targets themselves, the passes separated by glTextureBarrier; each fragment reads and
// writes only its own texel) in fixed blocks of 16 VALs, so that the sums do not depend on
// K_CACHE (gather_sum_block.glsl). Variants: GLOSSY, OCCLUSION (accumulate the second moments for S_o).
#include "lightskin_math.glsl"
#include "gather_val_chunk.glsl"
#include "gather_sparse_points.glsl"
#include "gather_sum_block.glsl"

uniform vec3 uEye;
uniform float uC;
// the running sums of the previous passes: the targets below (zero before the first pass)
layout(binding = 0) uniform sampler2D uSumDiffuse;
layout(binding = 1) uniform sampler2D uSumOffsetD;
layout(binding = 2) uniform sampler2D uSumGlossy;
layout(binding = 3) uniform sampler2D uSumOffsetS;
layout(binding = 4) uniform sampler2D uSumMoments;

layout(location = 0) out vec4 outDiffuse;   // L'_d.rgb, sum r^2 w_d
layout(location = 1) out vec4 outOffsetD;   // sum (l - x) w_d, W_d
layout(location = 2) out vec4 outGlossy;    // L'_s.rgb, sum r^2 w_s
layout(location = 3) out vec4 outOffsetS;   // sum (l - x) w_s, W_s
layout(location = 4) out vec4 outMoments;   // sum (l - x)^2 w_d per axis, sum |l - x|^2 w_s

void main() {
    const ivec2 texel = ivec2(gl_FragCoord.xy);
    if (gather_pointIndex(texel) >= uPointCount) discard;
    const vec4 positionK = texelFetch(uPointPosition, texel, 0);
    const vec3 x = positionK.xyz;
    const vec3 n = texelFetch(uPointNormal, texel, 0).xyz;
    const float k = positionK.w;
    const float ck = uC * (k + 1.0);
    const vec3 toEye = ls_toEye(x, uEye);
    GatherSums running;
    running.diffuse = texelFetch(uSumDiffuse, texel, 0);
    running.offsetD = texelFetch(uSumOffsetD, texel, 0);
    running.glossy = texelFetch(uSumGlossy, texel, 0);
    running.offsetS = texelFetch(uSumOffsetS, texel, 0);
    running.moments = texelFetch(uSumMoments, texel, 0);
    for (int first = 0; first < uValCount; first += kSumBlock) {
        GatherSums block = gather_zeroSums();
        const int end = min(first + kSumBlock, uValCount);
        for (int j = first; j < end; ++j) {
            const vec4 a = chunkVals[j].positionArea;
            const vec4 b = chunkVals[j].normal;
            const vec4 f = chunkVals[j].flux;
            block = gather_addSample(block, ls_gatherSample(x, n, a.xyz, b.xyz, a.w, f.rgb, toEye, k, ck, 0.0, LS_NEAR_FIELD != 0)); // eps_l folded in gather_renormalise.frag
        }
        running = gather_addBlock(running, block);
    }
    outDiffuse = running.diffuse;
    outOffsetD = running.offsetD;
    outGlossy = running.glossy;
    outOffsetS = running.offsetS;
    outMoments = running.moments;
}
