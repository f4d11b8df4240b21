#version 450 core
// Direct lighting of Lambertian surfaces by point lights and sampled area lights with exact
// shadow rays against the scene's boxes (radiometry in SceneRenderer.h and docs/SYNTH.md).
// Variant GEOMETRY_ONLY writes the exact position, depth and normal and skips the lighting.

#include "scene_lights.glsl"

in vec3 worldPosition;
in vec3 worldNormal;
in vec3 albedo;
in vec3 emission;
in vec2 texcoord;
in float cameraZ;

uniform vec3 cameraWorldPosition;
uniform bool useTagTexture;
uniform sampler2D tagTexture; // R8, 0 = black cell, 1 = white cell
uniform float tagBlackAlbedo;
uniform float tagWhiteAlbedo;

layout(location = 0) out vec4 outRadiance; // linear RGB radiance
layout(location = 1) out vec4 outPosition; // world xyz, w = camera z (metres)
layout(location = 2) out vec4 outNormal;   // world xyz, w = 1 where a surface was hit

void main() {
    vec3 normal = normalize(worldNormal);
    outPosition = vec4(worldPosition, cameraZ);
    outNormal = vec4(normal, 1.0);
#ifdef GEOMETRY_ONLY
    outRadiance = vec4(0.0, 0.0, 0.0, 1.0);
#else
    vec3 rho = albedo;
    if (useTagTexture) rho = vec3(mix(tagBlackAlbedo, tagWhiteAlbedo, texture(tagTexture, texcoord).r));
    vec3 radiance = rho * (directIrradiance(worldPosition, normal) / PI + ambientRadiance.rgb);
    if (dot(normal, cameraWorldPosition - worldPosition) > 0.0) radiance += emission;
    outRadiance = vec4(radiance, 1.0);
#endif
}
