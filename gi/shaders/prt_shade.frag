#version 450 core
// Multi-scale PRT shading: the diffuse indirect radiance rho_d / pi * E of the interpolated exit irradiance
// at every pixel whose G-buffer position is this fragment's (others are hidden surfaces: discarded).
layout(binding = 0) uniform sampler2D uGPosition; // xyz world, w = coverage
layout(binding = 2) uniform sampler2D uGAlbedo;
layout(location = 3) uniform vec3 uEye;
layout(location = 4) uniform float uPositionTolerance;

layout(location = 0) in vec3 vWorld;
layout(location = 1) in vec3 vIrradiance;
layout(location = 0) out vec4 outRadiance;

const float kPi = 3.14159265358979;

void main() {
    const ivec2 texel = ivec2(gl_FragCoord.xy);
    const vec4 position = texelFetch(uGPosition, texel, 0);
    if (position.w == 0.0) discard;
    const float tolerance = uPositionTolerance + 1e-4 * length(position.xyz - uEye);
    if (length(position.xyz - vWorld) > tolerance) discard;
    outRadiance = vec4(texelFetch(uGAlbedo, texel, 0).rgb / kPi * max(vIrradiance, vec3(0.0)), 0.0);
}
