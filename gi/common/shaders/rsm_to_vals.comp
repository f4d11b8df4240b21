#version 450 core
// Covered RSM texels -> VALs appended to a packed buffer (ReflectiveShadowMap.h has the math).
#include "virtual_area_light.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0) uniform sampler2D rsmPosition;
layout(binding = 1) uniform sampler2D rsmNormal;
layout(binding = 2) uniform sampler2D rsmAlbedo;
layout(std430, binding = 0) writeonly buffer Vals { VirtualAreaLight vals[]; };
layout(std430, binding = 2) buffer Counter { uint valCount; };
uniform int resolution;
uniform float tanHalfAngle;   // tan(beta) of the face's square frustum
uniform float minCosAlpha;    // cone: texels with cos(alpha) below this make no VAL (spot); -1 for cube faces
uniform vec3 lightPosition;
uniform vec3 intensity;       // W/sr
uniform bool areaFacingLight;
uniform float minCosine;
uniform uint capacity;

void main() {
    const ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(texel, ivec2(resolution)))) return;
    const vec4 position = texelFetch(rsmPosition, texel, 0);
    if (position.w == 0.0) return;
    // Texel centre ray in the face's view frame (image plane at distance 1).
    const vec2 ndc = (vec2(texel) + 0.5) / float(resolution) * 2.0 - 1.0;
    const float cosAlpha = inversesqrt(1.0 + dot(ndc, ndc) * tanHalfAngle * tanHalfAngle);
    if (cosAlpha < minCosAlpha) return;
    const float texelSide = 2.0 * tanHalfAngle / float(resolution);
    const float omega = texelSide * texelSide * cosAlpha * cosAlpha * cosAlpha;
    const vec3 toLight = lightPosition - position.xyz;
    const float distance2 = dot(toLight, toLight);
    const vec3 n = texelFetch(rsmNormal, texel, 0).xyz;
    float area = distance2 * omega;
    if (!areaFacingLight) area /= max(dot(n, toLight) * inversesqrt(distance2), minCosine);
    if (!(area > 0.0)) return; // a surface exactly at the light
    const uint index = atomicAdd(valCount, 1u);
    if (index >= capacity) return;
    VirtualAreaLight val;
    val.positionArea = vec4(position.xyz, area);
    val.normal = vec4(n, 0.0);
    val.flux = vec4(texelFetch(rsmAlbedo, texel, 0).rgb * intensity * omega, 0.0);
    vals[index] = val;
}
