#version 450 core
// World-space triangles of the synthetic room, projected with OpenCV intrinsics (see
// SceneRenderer.cpp: projectionFromIntrinsics). The camera-frame z is passed on so the fragment
// shader writes the exact depth along the optical axis at the pixel centre.

layout(location = 0) in vec3 inPosition; // world metres
layout(location = 1) in vec3 inNormal;   // world, unit
layout(location = 2) in vec3 inAlbedo;   // linear RGB
layout(location = 3) in vec3 inEmission; // radiance of the front face, W m^-2 sr^-1
layout(location = 4) in vec2 inTexcoord; // tag bitmap coordinates (0,0) top-left

uniform mat4 camera_T_world;
uniform mat4 clip_T_camera;

out vec3 worldPosition;
out vec3 worldNormal;
out vec3 albedo;
out vec3 emission;
out vec2 texcoord;
out float cameraZ;

void main() {
    vec4 cameraPosition = camera_T_world * vec4(inPosition, 1.0);
    worldPosition = inPosition;
    worldNormal = inNormal;
    albedo = inAlbedo;
    emission = inEmission;
    texcoord = inTexcoord;
    cameraZ = cameraPosition.z;
    gl_Position = clip_T_camera * cameraPosition;
}
