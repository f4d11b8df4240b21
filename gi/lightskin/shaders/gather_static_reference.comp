#version 450 core
// Static content, tolerance mode: the largest gathered irradiance max_x max_rgb L'_d(x) of a full
// computation (the scale of the tolerance). Non-negative floats order like their bit patterns.
layout(local_size_x = 64) in;
layout(binding = 0) uniform sampler2D uDiffuse; // gather target 0: L'_d.rgb
layout(std430, binding = 3) buffer Check { float bound; uint referenceBits; uint badKeys; uint referenceBadKeys; };
uniform int uPointCount;

void main() {
    const int i = int(gl_GlobalInvocationID.x);
    if (i >= uPointCount) return;
    const int width = textureSize(uDiffuse, 0).x;
    const vec3 e = texelFetch(uDiffuse, ivec2(i % width, i / width), 0).rgb;
    const float m = max(max(e.r, e.g), e.b);
    if (m > 0.0) atomicMax(referenceBits, floatBitsToUint(m)); // NaN fails m > 0
}
