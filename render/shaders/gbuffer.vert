#version 450 core
// G-buffer pass: model -> world -> clip (clip_T_world from render/CameraProjection.h).
layout(location = 0) in vec3 positionModel;
layout(location = 1) in vec3 normalModel;
layout(location = 2) in vec2 texcoord;

uniform mat4 world_T_model;
uniform mat3 normalMatrix; // inverse transpose of world_T_model's 3x3
uniform mat4 clip_T_world;

layout(location = 0) out vec3 positionWorld;
layout(location = 1) out vec3 normalWorld;
layout(location = 2) out vec2 uv;

void main() {
    const vec4 world = world_T_model * vec4(positionModel, 1.0);
    positionWorld = world.xyz;
    normalWorld = normalMatrix * normalModel;
    uv = texcoord;
    gl_Position = clip_T_world * world;
}
