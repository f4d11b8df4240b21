#version 450 core
// Self-test (lightskin doctor, GL tests): a triangle with a solid colour per vertex.
layout(location = 0) out vec3 colour;
const vec2 positions[3] = vec2[](vec2(-0.5, -0.5), vec2(0.5, -0.5), vec2(0.0, 0.5));
void main() {
    colour = vec3(TRIANGLE_RED, 0.0, 0.0);
    gl_Position = vec4(positions[gl_VertexID], 0.0, 1.0);
}
