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

layout(location = 0) out vec4 outDiffuse;   // L''_d.rgb, rbar^2_d
layout(location = 1) out vec4 outPositionD; // l'_d.xyz, S_o radius (diffuse)
layout(location = 2) out vec4 outGlossy;    // L''_s.rgb, rbar^2_s
layout(location = 3) out vec4 outPositionS; // l'_s.xyz, S_o radius (glossy)

void main() {
    const ivec2 texel = ivec2(gl_FragCoord.xy);
    if (gather_pointIndex(texel) >= uPointCount) discard;
    const vec4 positionK = texelFetch(uPointPosition, texel, 0);
    const vec3 x = positionK.xyz;
    const vec3 n = texelFetch(uPointNormal, texel, 0).xyz;
    const vec4 d = texelFetch(uDiffuse, texel, 0);
    const vec4 od = texelFetch(uOffsetD, texel, 0);
    const vec4 g = texelFetch(uGlossy, texel, 0);
    const vec4 os = texelFetch(uOffsetS, texel, 0);
    const vec4 m = texelFetch(uMoments, texel, 0);
    const Vpl vd = ls_renormaliseDiffuse(d.rgb, od.xyz, od.w, d.w, m.xyz, x, n);
    const Vpl vs = ls_renormaliseGlossy(g.rgb, os.xyz, os.w, g.w, m.w, x, n, ls_toEye(x, uEye), positionK.w);
    outDiffuse = vec4(vd.radiance, vd.r2);
    outPositionD = vec4(vd.position, vd.sphereRadius);
    outGlossy = vec4(vs.radiance, vs.r2);
    outPositionS = vec4(vs.position, vs.sphereRadius);
}
