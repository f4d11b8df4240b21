#version 450 core
// Gather (eq. 3-5, 7 without the eps_l terms, see gather_val_sums.comp; the paper's Listing 1): one fragment per sparse point, K_CACHE VALs per
// pass from the uniform block, added to the targets by additive blending. Variants: GLOSSY,
// OCCLUSION (accumulate the second moments for S_o).
#include "lightskin_math.glsl"
#include "gather_val_chunk.glsl"
#include "gather_sparse_points.glsl"

uniform vec3 uEye;
uniform float uC;

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
    vec4 diffuse = vec4(0.0), offsetD = vec4(0.0), glossy = vec4(0.0), offsetS = vec4(0.0), moments = vec4(0.0);
    for (int j = 0; j < uValCount; ++j) {
        const vec4 a = chunkVals[j].positionArea;
        const vec4 b = chunkVals[j].normal;
        const vec4 f = chunkVals[j].flux;
        const GatherSample s = ls_gatherSample(x, n, a.xyz, b.xyz, a.w, f.rgb, toEye, k, ck, 0.0); // eps_l folded in gather_renormalise.frag
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
    outDiffuse = diffuse;
    outOffsetD = offsetD;
    outGlossy = glossy;
    outOffsetS = offsetS;
    outMoments = moments;
}
