#version 450 core
// Shadow cube face: world position for the distance, clip position of this face's camera.
layout(location = 0) in vec3 positionModel;
uniform mat4 world_T_model;
uniform mat4 clip_T_world;
layout(location = 0) out vec3 positionWorld;
void main() {
    const vec4 world = world_T_model * vec4(positionModel, 1.0);
    positionWorld = world.xyz;
    gl_Position = clip_T_world * world;
}
