#version 450 core
// Draws a session's last frame into the host's target (mr::Session::render).
// mode 0 (virtual only): the renderer's colour output (RGBA8, a = coverage) and depth (R32F camera
//   z, metres), both in GL row order like the target; uncovered pixels are discarded; with
//   writeDepth the window depth of z under the projection (near, far), as render::clipFromCamera:
//   z_ndc = (f + n) / (f - n) - 2 f n / ((f - n) z), window = 0.5 z_ndc + 0.5 (default depth range).
// mode 1 (composite): the CPU composite uploaded top row first, so v is flipped.
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 colour;
layout(binding = 0) uniform sampler2D image;
layout(binding = 1) uniform sampler2D virtualDepth;
uniform int mode;
uniform bool writeDepth;
uniform float nearMetres;
uniform float farMetres;

void main() {
    // Nearest texel (a viewport of the camera's size maps pixel centres onto texel centres).
    const ivec2 size = textureSize(image, 0);
    const ivec2 texel = clamp(ivec2(uv * vec2(size)), ivec2(0), size - 1);
    if (mode == 1) {
        colour = vec4(texelFetch(image, ivec2(texel.x, size.y - 1 - texel.y), 0).rgb, 1.0);
        gl_FragDepth = gl_FragCoord.z;
        return;
    }
    const vec4 c = texelFetch(image, texel, 0);
    if (c.a == 0.0) discard;
    colour = vec4(c.rgb, 1.0);
    if (writeDepth) {
        const float z = max(texelFetch(virtualDepth, texel, 0).r, nearMetres);
        const float n = nearMetres, f = farMetres;
        const float ndc = (f + n) / (f - n) - 2.0 * f * n / ((f - n) * z);
        gl_FragDepth = clamp(0.5 * ndc + 0.5, 0.0, 1.0);
    } else {
        gl_FragDepth = gl_FragCoord.z;
    }
}
