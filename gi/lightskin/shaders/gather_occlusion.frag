#version 450 core
// Occlusion (section 3.3, eq. 14): how much of each sparse point's S_o spheres the occluder
// discs [uOccluderBegin, uOccluderBegin + uOccluderCount) hide. Additive over passes; the sum is
// clamped to [0, 1] where it is applied (gather_interpolate.comp). x = diffuse, y = glossy.
#include "lightskin_math.glsl"
#include "gather_sparse_points.glsl"

layout(binding = 1) uniform sampler2D uPositionD;
layout(binding = 3) uniform sampler2D uPositionS;
uniform int uOccluderBegin;
uniform int uOccluderCount;

layout(location = 0) out vec4 outOcclusion;

void main() {
    const ivec2 texel = ivec2(gl_FragCoord.xy);
    if (gather_pointIndex(texel) >= uPointCount) discard;
    const vec3 x = texelFetch(uPointPosition, texel, 0).xyz;
    const vec3 n = texelFetch(uPointNormal, texel, 0).xyz;
    const vec3 t = ls_tangent(n);
    const vec3 b = ls_binormal(n);
    const vec4 pd = texelFetch(uPositionD, texel, 0);
    const vec4 ps = texelFetch(uPositionS, texel, 0);
    const OcclusionTarget targetD = ls_occlusionTarget(x, n, t, b, pd.xyz, pd.w);
#ifdef GLOSSY
    const OcclusionTarget targetS = ls_occlusionTarget(x, n, t, b, ps.xyz, ps.w);
#endif
    vec2 sum = vec2(0.0);
    for (int i = 0; i < uOccluderCount; ++i) {
        const ivec2 o = gather_pointTexel(uOccluderBegin + i);
        const vec3 y = texelFetch(uPointPosition, o, 0).xyz;
        const vec4 ny = texelFetch(uPointNormal, o, 0);
        sum.x += ls_occluderAmount(targetD, x, n, t, b, y, ny.xyz, ny.w);
#ifdef GLOSSY
        sum.y += ls_occluderAmount(targetS, x, n, t, b, y, ny.xyz, ny.w);
#endif
    }
    outOcclusion = vec4(sum, 0.0, 0.0);
}
