#version 450 core
// Renormalisation (eq. 8-11): the averaged VPLs (L'', l') of each sparse point, plus the radius
// of its occlusion sphere S_o (section 3.3).
#include "lightskin_math.glsl"
#include "gather_sparse_points.glsl"

layout(binding = 0) uniform sampler2D uDiffuse;
layout(binding = 1) uniform sampler2D uOffsetD;
layout(binding = 2) uniform sampler2D uGlossy;
layout(binding = 3) uniform sampler2D uOffsetS;
layout(binding = 4) uniform sampler2D uMoments;
uniform vec3 uEye;
uniform float uEpsilonL;
uniform int uGlossyOn;    // 0: the glossy sums stay empty (no eps_l terms either), like the reference
uniform int uOcclusionOn; // 0: no moments were gathered
uniform float uHorizonSpread; // G9: 1 = extended VPL horizon (robust model), 0 = point VPL
// sum over all valid VALs: (sum l, sum r^2), (sum l^2 per axis, count), see gather_val_sums.comp
layout(std430, binding = 3) readonly buffer ValSums { vec4 valSums[2]; };

layout(location = 0) out vec4 outDiffuse;   // L''_d.rgb, rbar^2_d
layout(location = 1) out vec4 outPositionD; // l'_d.xyz, S_o radius (diffuse)
layout(location = 2) out vec4 outGlossy;    // L''_s.rgb, rbar^2_s
layout(location = 3) out vec4 outPositionS; // l'_s.xyz, S_o radius (glossy)

void main() {
    const ivec2 texel = ivec2(gl_FragCoord.xy);
    if (gather_pointIndex(texel) >= uPointCount) discard;
    const vec4 positionK = texelFetch(uPointPosition, texel, 0);
    const vec3 x = positionK.xyz;
    const vec4 d = texelFetch(uDiffuse, texel, 0);
    const vec4 od = texelFetch(uOffsetD, texel, 0);
    const vec4 g = texelFetch(uGlossy, texel, 0);
    const vec4 os = texelFetch(uOffsetS, texel, 0);
    const vec4 m = texelFetch(uMoments, texel, 0);
    // eps_l terms of eq. 7, folded: sum_j eps (l_j - x), sum_j eps, sum_j eps r_j^2, sum_j eps (l_j - x)^2
    const float n = valSums[1].w;
    const vec3 epsOffset = uEpsilonL * (valSums[0].xyz - n * x);
    const float epsW = uEpsilonL * n;
    const float epsR2 = uEpsilonL * valSums[0].w;
    const vec3 epsMoment = float(uOcclusionOn) * uEpsilonL * max(valSums[1].xyz - 2.0 * x * valSums[0].xyz + n * x * x, vec3(0.0));
    const vec3 nx = texelFetch(uPointNormal, texel, 0).xyz;
    const Vpl vd = ls_renormaliseDiffuse(d.rgb, od.xyz + epsOffset, od.w + epsW, d.w + epsR2, m.xyz + epsMoment, x, nx, uHorizonSpread);
    const float glossyEps = float(uGlossyOn);
    const Vpl vs = ls_renormaliseGlossy(g.rgb, os.xyz + glossyEps * epsOffset, os.w + glossyEps * epsW, g.w + glossyEps * epsR2,
                                        m.w + glossyEps * (epsMoment.x + epsMoment.y + epsMoment.z), x, nx, ls_toEye(x, uEye), positionK.w);
    outDiffuse = vec4(vd.radiance, vd.r2);
    outPositionD = vec4(vd.position, vd.sphereRadius);
    outGlossy = vec4(vs.radiance, vs.r2);
    outPositionS = vec4(vs.position, vs.sphereRadius);
}
