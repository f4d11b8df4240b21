#version 450 core
// Minimal G-buffer (SimpleGBuffer, tests and benchmarks).
layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
uniform mat4 uClipFromWorld;
uniform mat4 uWorldFromModel;
uniform mat3 uNormalFromModel;
layout(location = 0) out vec3 vWorld;
layout(location = 1) out vec3 vNormal;
void main() {
    const vec4 world = uWorldFromModel * vec4(inPosition, 1.0);
    vWorld = world.xyz;
    vNormal = uNormalFromModel * inNormal;
    gl_Position = uClipFromWorld * world;
}
