#version 450 core
// ValOccupancyCull, pass 1: the virtual meshes from the camera; each fragment's depth along the
// optical axis goes to a MIN-blended (z, -z) target: per pixel the nearest and farthest virtual surface.
layout(location = 0) in vec3 inPosition;
uniform mat4 uClipFromWorld;
uniform mat4 uWorldFromModel;
uniform mat4 uCameraFromWorld;
layout(location = 0) out float vDepth;

void main() {
    const vec4 world = uWorldFromModel * vec4(inPosition, 1.0);
    vDepth = (uCameraFromWorld * world).z;
    gl_Position = uClipFromWorld * world;
}
