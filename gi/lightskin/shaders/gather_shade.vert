#version 450 core
// Per-pixel shading, vertex stage: the mesh is re-rasterised; each vertex hands its averaged
// VPLs (eq. 13) to the rasteriser, which interpolates them per pixel.
#include "gather_vertex_vpl.glsl"

layout(location = 0) in vec3 inPosition;
layout(std430, binding = 1) readonly buffer VertexVpls { VertexVpl vertexVpls[]; };
uniform mat4 uClipFromWorld;
uniform mat4 uWorldFromModel;
uniform uint uFirstVertex;

layout(location = 0) out vec3 vWorld;
layout(location = 1) out vec4 vDiffuse;
layout(location = 2) out vec4 vDiffusePosition; // l'''_d, S_o radius (G9)
layout(location = 3) out vec4 vGlossy;
layout(location = 4) out vec4 vGlossyPosition; // l'''_s, G10 cap

void main() {
    const VertexVpl vpl = vertexVpls[uFirstVertex + uint(gl_VertexID)];
    const vec4 world = uWorldFromModel * vec4(inPosition, 1.0);
    vWorld = world.xyz;
    vDiffuse = vpl.diffuse;
    vDiffusePosition = vpl.diffusePosition;
    vGlossy = vpl.glossy;
    vGlossyPosition = vpl.glossyPosition;
    gl_Position = uClipFromWorld * world;
}
