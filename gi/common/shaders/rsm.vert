#version 450 core
// Reflective shadow map of the virtual content seen from one light face (ReflectiveShadowMap).
layout(location = 0) in vec3 modelPosition;
layout(location = 1) in vec3 modelNormal;
uniform mat4 world_T_model; // rigid + uniform scale
uniform mat4 lightClip_T_world;
out vec3 worldPosition;
out vec3 worldNormal;
void main() {
    const vec4 world = world_T_model * vec4(modelPosition, 1.0);
    worldPosition = world.xyz;
    worldNormal = mat3(world_T_model) * modelNormal;
    gl_Position = lightClip_T_world * world;
}
