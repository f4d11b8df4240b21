#version 450 core
layout(location = 0) in vec3 vWorld;
layout(location = 1) in vec3 vNormal;
uniform vec3 uAlbedo;
uniform vec4 uSpecular;
layout(location = 0) out vec4 outPosition;
layout(location = 1) out vec4 outNormal;
layout(location = 2) out vec4 outAlbedo;
layout(location = 3) out vec4 outSpecular;
void main() {
    // As render/shaders/gbuffer.frag: a back face's normal turned toward the viewer, w = 1 flags it.
    const vec3 n = normalize(vNormal);
    outPosition = vec4(vWorld, 1.0);
    outNormal = gl_FrontFacing ? vec4(n, 0.0) : vec4(-n, 1.0);
    outAlbedo = vec4(uAlbedo, 1.0);
    outSpecular = uSpecular;
}
