#version 450 core
// Multi-scale PRT shading: the diffuse indirect radiance rho_d / pi * E * S of the interpolated exit irradiance
// E at every pixel whose G-buffer position is this fragment's (others are hidden surfaces: discarded). S is the
// small-scale ambient occlusion (paper 004, sec. 10: the irradiance, obscurance and ambient-occlusion textures
// are multiplied); it multiplies this indirect light only, the renderer's direct light never sees it. Modes and
// formulas: gi/prt/include/lightskin/gi/prt/MultiscalePrt.h, "Small scale".
layout(binding = 0) uniform sampler2D uGPosition; // xyz world, w = coverage
layout(binding = 1) uniform sampler2D uGNormal;   // w = 1 on a back face
layout(binding = 2) uniform sampler2D uGAlbedo;
layout(binding = 3) uniform sampler2D uSmallScaleMap; // mode 1: occlusion in r; mode 2: tangent-space normal rgb
layout(location = 3) uniform vec3 uEye;
layout(location = 4) uniform float uPositionTolerance;
layout(location = 5) uniform int uSmallScaleMode; // 0 off, 1 occlusion map, 2 normal-map estimate
layout(location = 6) uniform float uSmallScaleFactor; // mode 1: occlusion strength; mode 2: normal scale

layout(location = 0) in vec3 vWorld;
layout(location = 1) in vec3 vIrradiance;
layout(location = 2) in vec2 vTexcoord;
layout(location = 0) out vec4 outRadiance;

const float kPi = 3.14159265358979;

float smallScaleOcclusion() {
    if (uSmallScaleMode == 1) return 1.0 + uSmallScaleFactor * (texture(uSmallScaleMap, vTexcoord).r - 1.0);
    if (uSmallScaleMode == 2) {
        // The paper's W(alpha, h = 1) = (1 + cos alpha) / 2: the cosine-weighted part of the detail normal's
        // hemisphere above the mean surface. cos alpha is the tangent-space normal's z (the mean normal is +z).
        vec3 n = texture(uSmallScaleMap, vTexcoord).rgb * 2.0 - 1.0;
        n.xy *= uSmallScaleFactor;
        const float len = length(n);
        const float cosAlpha = len > 0.0 ? clamp(n.z / len, -1.0, 1.0) : 1.0;
        return 0.5 + 0.5 * cosAlpha;
    }
    return 1.0;
}

void main() {
    // Sampled before the discards: implicit derivatives (mip selection) need the whole 2x2 quad still running.
    const float smallScale = smallScaleOcclusion();
    const ivec2 texel = ivec2(gl_FragCoord.xy);
    const vec4 position = texelFetch(uGPosition, texel, 0);
    if (position.w == 0.0) discard;
    const float tolerance = uPositionTolerance + 1e-4 * length(position.xyz - uEye);
    if (length(position.xyz - vWorld) > tolerance) discard;
    // A back face (w = 1) is the object's inside seen through a hole in its mesh: no light (the target is
    // cleared to 0), as LightSkin and the brute force; why 0: gi::GBufferView::worldNormal. Its vertices'
    // exit irradiance is the outside's light. And, as gather_shade.frag, a back-facing fragment within the
    // position tolerance (a scan folding over itself) never shades a front-face pixel.
    if (texelFetch(uGNormal, texel, 0).w > 0.5 || !gl_FrontFacing) discard;
    const vec3 radiance = texelFetch(uGAlbedo, texel, 0).rgb / kPi * max(vIrradiance, vec3(0.0));
    outRadiance = vec4(radiance * smallScale, 0.0);
}
