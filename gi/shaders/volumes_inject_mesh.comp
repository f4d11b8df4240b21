#version 450 core
// Section 3.1: uPerTriangle random points per triangle with density 1/A (u1, u2 from the PCG hash
// of the point id, as the reference's sampleTriangles), normal interpolated, no radiance.
#include "volumes_inject.glsl"

layout(local_size_x = 64) in;
layout(std430, binding = 6) readonly buffer Positions { vec4 positions[]; }; // model space, metres
layout(std430, binding = 7) readonly buffer Normals { vec4 normals[]; };
layout(std430, binding = 8) readonly buffer Indices { uint indices[]; };
layout(location = 3) uniform uint uPointCount; // triangles * uPerTriangle
layout(location = 8) uniform uint uPointOffset; // of this dispatch (at most 65535 groups each)
layout(location = 4) uniform uint uPerTriangle;
layout(location = 5) uniform uint uSeed;
layout(location = 6) uniform mat4 uWorldFromModel;
layout(location = 7) uniform vec3 uAlbedo;

void main() {
    const uint id = uPointOffset + gl_GlobalInvocationID.x;
    if (id >= uPointCount) return;
    const uint t = id / uPerTriangle;
    const float u1 = unitFromHash(pcgHash(uSeed ^ (2u * id)));
    const float u2 = unitFromHash(pcgHash(uSeed ^ (2u * id + 1u)));
    const float s = sqrt(u1);
    const vec3 w = vec3(1.0 - s, s * (1.0 - u2), s * u2);
    const uint i0 = indices[3u * t], i1 = indices[3u * t + 1u], i2 = indices[3u * t + 2u];
    const vec3 p = w.x * positions[i0].xyz + w.y * positions[i1].xyz + w.z * positions[i2].xyz;
    const vec3 n = w.x * normals[i0].xyz + w.y * normals[i1].xyz + w.z * normals[i2].xyz;
    const vec3 wn = mat3(uWorldFromModel) * n;
    const float len = length(wn);
    injectPoint((uWorldFromModel * vec4(p, 1.0)).xyz, len > 0.0 ? wn / len : vec3(0.0), vec3(0.0), uAlbedo, false);
}
