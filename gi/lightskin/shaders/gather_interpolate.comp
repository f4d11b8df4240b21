#version 450 core
// Vertex interpolation (eq. 12-13): per vertex of one mesh instance, the weighted average of the
// renormalised (and occlusion-attenuated) VPLs of its 8 nearest sparse points, in world space.
#include "lightskin_math.glsl"
#include "gather_sparse_points.glsl"
#include "gather_vertex_vpl.glsl"

layout(local_size_x = 64) in;

struct VertexInput {
    vec4 position;      // model space xyz
    vec4 normal;        // model space xyz
    uvec4 neighbours0;  // global sparse-point indices, nearest first
    uvec4 neighbours1;
};
layout(std430, binding = 0) readonly buffer VertexInputs { VertexInput vertexInputs[]; };
layout(std430, binding = 1) writeonly buffer VertexVpls { VertexVpl vertexVpls[]; };

layout(binding = 0) uniform sampler2D uDiffuse;
layout(binding = 1) uniform sampler2D uPositionD;
layout(binding = 2) uniform sampler2D uGlossy;
layout(binding = 3) uniform sampler2D uPositionS;
layout(binding = 4) uniform sampler2D uOcclusion;
layout(binding = 5) uniform sampler2D uGathered; // L'_d of eq. 7 (the gather's first target), for G10
uniform mat4 uWorldFromModel;
uniform mat3 uNormalFromModel;
uniform uint uFirstVertex;
uniform uint uVertexCount;
uniform int uApplyOcclusion;
uniform float uHorizonSpread; // G9: 0 = shade point VPLs (the diffuse S_o radius not handed on)
uniform int uIrradianceCap;   // G10: 1 = cap the shaded diffuse irradiance (glossyPosition.w)
// G11: the registered real depth (gi::RealDepthView): R32F metres, texel (u, v) = image column u, row v
// from the top; <= 0 or NaN = hole. uBuriedRule 0 = no depth (no point is buried).
layout(binding = 6) uniform sampler2D uRealDepth;
uniform int uBuriedRule;
uniform mat4 uCameraFromWorld; // rigid, OpenCV camera frame (x right, y down, z forward)
uniform vec4 uRealIntrinsics;  // fx, fy, cx, cy (pixels)

// G11: the sparse point at world position x lies under the real surface (lightskin_math.glsl).
bool buriedUnderRealSurface(vec3 x) {
    if (uBuriedRule == 0) return false;
    const vec3 pc = (uCameraFromWorld * vec4(x, 1.0)).xyz;
    if (!(pc.z > 0.0)) return false;
    const vec2 pixel = floor(ls_projectToPixel(pc, uRealIntrinsics.x, uRealIntrinsics.y, uRealIntrinsics.z,
                                               uRealIntrinsics.w) + 0.5);
    const vec2 size = vec2(textureSize(uRealDepth, 0));
    // Written so that NaN fails: outside the image is not buried.
    if (!(pixel.x >= 0.0 && pixel.y >= 0.0 && pixel.x < size.x && pixel.y < size.y)) return false;
    return ls_isBuried(pc.z, texelFetch(uRealDepth, ivec2(pixel), 0).r);
}

void main() {
    const uint local = gl_GlobalInvocationID.x;
    if (local >= uVertexCount) return;
    const uint v = uFirstVertex + local;
    const VertexInput vin = vertexInputs[v];
    const vec3 p = (uWorldFromModel * vec4(vin.position.xyz, 1.0)).xyz;
    const vec3 nv = normalize(uNormalFromModel * vin.normal.xyz);
    uint index[kNeighbours];
    float dist[kNeighbours];
    float cosN[kNeighbours];
    bool unique[kNeighbours];
    bool buried[kNeighbours];
    for (int j = 0; j < kNeighbours; ++j) {
        index[j] = j < 4 ? vin.neighbours0[j] : vin.neighbours1[j - 4];
        const ivec2 texel = gather_pointTexel(int(index[j]));
        const vec3 x = texelFetch(uPointPosition, texel, 0).xyz;
        dist[j] = length(p - x);
        cosN[j] = dot(nv, texelFetch(uPointNormal, texel, 0).xyz);
        unique[j] = j == 0 || index[j] != index[j - 1];
        buried[j] = buriedUnderRealSurface(x); // G11
    }
    const VertexWeights weights = ls_vertexWeightsAboveSurface(dist, cosN, unique, buried);
    VertexVpl result;
    result.diffuse = vec4(0.0);
    result.diffusePosition = vec4(0.0);
    result.glossy = vec4(0.0);
    result.glossyPosition = vec4(0.0);
    float minDD = 3.0e38, minDS = 3.0e38; // G8
    float cap = 0.0;                      // G10
    for (int j = 0; j < kNeighbours; ++j) {
        const float w = weights.w[j];
        if (w == 0.0) continue;
        const ivec2 texel = gather_pointTexel(int(index[j]));
        const vec3 x = texelFetch(uPointPosition, texel, 0).xyz;
        const vec3 od = texelFetch(uPositionD, texel, 0).xyz - x, os = texelFetch(uPositionS, texel, 0).xyz - x;
        minDD = min(minDD, dot(od, od) + texelFetch(uDiffuse, texel, 0).w);
        minDS = min(minDS, dot(os, os) + texelFetch(uGlossy, texel, 0).w);
        vec2 keep = vec2(1.0);
        if (uApplyOcclusion != 0) keep = vec2(1.0) - clamp(texelFetch(uOcclusion, texel, 0).xy, 0.0, 1.0);
        const vec4 d = texelFetch(uDiffuse, texel, 0);
        const vec4 g = texelFetch(uGlossy, texel, 0);
        cap = max(cap, ls_peakChannel(texelFetch(uGathered, texel, 0).rgb) * keep.x); // G10
        result.diffuse += w * vec4(d.rgb * keep.x, d.w);
        result.diffusePosition += w * texelFetch(uPositionD, texel, 0) * vec4(1.0, 1.0, 1.0, uHorizonSpread);
        result.glossy += w * vec4(g.rgb * keep.y, g.w);
        result.glossyPosition += w * vec4(texelFetch(uPositionS, texel, 0).xyz, 0.0);
    }
    result.diffuse.w = ls_vertexR2Floor(result.diffuse.w, p, result.diffusePosition.xyz, minDD);
    result.glossy.w = ls_vertexR2Floor(result.glossy.w, p, result.glossyPosition.xyz, minDS);
    result.glossyPosition.w = uIrradianceCap != 0 ? cap : -1.0;
    vertexVpls[v] = result;
}
