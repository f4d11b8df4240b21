#version 450 core
// Per-pixel shading (eq. 10) of the interpolated VPLs with the G-buffer's position, normal and
// material. A fragment whose position is not the G-buffer's is a hidden surface: discarded.
#include "lightskin_math.glsl"

layout(binding = 0) uniform sampler2D uGPosition; // xyz world, w = coverage
layout(binding = 1) uniform sampler2D uGNormal;
layout(binding = 2) uniform sampler2D uGAlbedo;
layout(binding = 3) uniform sampler2D uGSpecular; // rgb f_s, a = k
uniform vec3 uEye;
uniform float uPositionTolerance;
uniform int uGlossy;

layout(location = 0) in vec3 vWorld;
layout(location = 1) in vec4 vDiffuse;
layout(location = 2) in vec4 vDiffusePosition;
layout(location = 3) in vec4 vGlossy;
layout(location = 4) in vec4 vGlossyPosition; // l'''_s, G10 cap (< 0: none)
layout(location = 0) out vec4 outRadiance;

void main() {
    const ivec2 texel = ivec2(gl_FragCoord.xy);
    const vec4 position = texelFetch(uGPosition, texel, 0);
    if (position.w == 0.0) discard;
    const float tolerance = uPositionTolerance + 1e-4 * length(position.xyz - uEye);
    if (length(position.xyz - vWorld) > tolerance) discard;
    const vec4 normal = texelFetch(uGNormal, texel, 0);
    // A back face (w = 1) is the object's inside seen through a hole in its mesh: no light (the target
    // is cleared to 0). Why 0: gi::GBufferView::worldNormal. And a back-facing fragment never shades a
    // front-face pixel: where a scan folds over itself (bun_zipper_res4.ply), a triangle wound the other
    // way lies within the position tolerance behind the visible one; its VPLs sit on its own side, behind
    // the G-buffer's normal, and drawn last it wrote 0 over the visible surface's light.
    if (normal.w > 0.5 || !gl_FrontFacing) discard;
    const vec3 n = normalize(normal.xyz);
    const vec3 rhoD = texelFetch(uGAlbedo, texel, 0).rgb;
    const vec4 specular = texelFetch(uGSpecular, texel, 0);
    Vpl d;
    d.radiance = vDiffuse.rgb;
    d.r2 = vDiffuse.w;
    d.position = vDiffusePosition.xyz;
    d.sphereRadius = vDiffusePosition.w; // G9 (0 without it)
    vec3 radiance = rhoD * ls_capIrradiance(ls_applyDiffuse(d, position.xyz, n), vGlossyPosition.w) / kPi;
    if (uGlossy != 0) {
        Vpl s;
        s.radiance = vGlossy.rgb;
        s.r2 = vGlossy.w;
        s.position = vGlossyPosition.xyz;
        s.sphereRadius = 0.0;
        radiance += specular.rgb * ls_applyGlossy(s, position.xyz, n, ls_toEye(position.xyz, uEye), specular.a);
    }
    outRadiance = vec4(radiance, 0.0);
}
