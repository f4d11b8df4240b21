#version 450 core
// Brute force (eq. 2 with 4 and 5): every VAL of this chunk applied to every covered G-buffer
// pixel, no interpolation, no occlusion. Additive over chunks. Variant: GLOSSY.
#include "lightskin_math.glsl"
#include "gather_val_chunk.glsl"

layout(binding = 0) uniform sampler2D uGPosition;
layout(binding = 1) uniform sampler2D uGNormal;
layout(binding = 2) uniform sampler2D uGAlbedo;
layout(binding = 3) uniform sampler2D uGSpecular;
uniform vec3 uEye;
uniform float uC;

layout(location = 0) out vec4 outRadiance;

void main() {
    const ivec2 texel = ivec2(gl_FragCoord.xy);
    const vec4 position = texelFetch(uGPosition, texel, 0);
    const vec4 normal = texelFetch(uGNormal, texel, 0);
    // Uncovered, or a back face (w = 1: the object's inside seen through a hole in its mesh, dark as in
    // LightSkin; gi::GBufferView::worldNormal).
    if (position.w == 0.0 || normal.w > 0.5) {
        outRadiance = vec4(0.0);
        return;
    }
    const vec3 x = position.xyz;
    const vec3 n = normalize(normal.xyz);
    const vec3 rhoD = texelFetch(uGAlbedo, texel, 0).rgb;
    const vec4 specular = texelFetch(uGSpecular, texel, 0);
#ifdef GLOSSY
    const vec3 fs = specular.rgb;
#else
    const vec3 fs = vec3(0.0);
#endif
    const float k = max(specular.a, 1.0);
    const float ck = uC * (k + 1.0);
    const vec3 toEye = ls_toEye(x, uEye);
    vec3 sum = vec3(0.0);
    for (int j = 0; j < uValCount; ++j) {
        const vec4 a = chunkVals[j].positionArea;
        const vec4 b = chunkVals[j].normal;
        const vec4 f = chunkVals[j].flux;
#ifdef GLOSSY
        sum += ls_bruteForceRadiance(ls_gatherSample(x, n, a.xyz, b.xyz, a.w, f.rgb, toEye, k, ck, 0.0, LS_NEAR_FIELD != 0), rhoD, fs);
#else
        sum += ls_irradiance(x, n, a.xyz, b.xyz, a.w, f.rgb, LS_NEAR_FIELD != 0);
#endif
    }
#ifndef GLOSSY
    sum *= rhoD / kPi;
#endif
    outRadiance = vec4(sum, 0.0);
}
