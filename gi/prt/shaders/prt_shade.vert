#version 450 core
// Multi-scale PRT shading, vertex stage: the mesh is re-rasterised and each vertex (exit point) hands its
// precomputed-transfer irradiance to the rasteriser, which interpolates it per pixel; the texture coordinates
// (attribute 2; (0, 0) when the mesh has none) address the small-scale map.
layout(location = 0) in vec3 inPosition;
layout(location = 2) in vec2 inTexcoord;
layout(std430, binding = 1) readonly buffer ExitIrradiance { vec4 exitIrradiance[]; };
layout(location = 0) uniform mat4 uClipFromWorld;
layout(location = 1) uniform mat4 uWorldFromModel;
layout(location = 2) uniform uint uFirstVertex;

layout(location = 0) out vec3 vWorld;
layout(location = 1) out vec3 vIrradiance;
layout(location = 2) out vec2 vTexcoord;

void main() {
    const vec4 world = uWorldFromModel * vec4(inPosition, 1.0);
    vWorld = world.xyz;
    vIrradiance = exitIrradiance[uFirstVertex + uint(gl_VertexID)].rgb;
    vTexcoord = inTexcoord;
    gl_Position = uClipFromWorld * world;
}
