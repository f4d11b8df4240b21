#version 450 core
// Static content, tolerance mode with probes: max over probes and channels of |L'_d,new - L'_d,ref|
// (the probe gather of this frame's VALs against that of the last full computation) into
// Check.bound. Non-negative floats order like their bit patterns; NaN makes the check fail.
layout(local_size_x = 64) in;
layout(binding = 0) uniform sampler2D uProbeNew;       // L'_d.rgb at the probes, this frame
layout(binding = 1) uniform sampler2D uProbeReference; // the same at the last full computation
layout(std430, binding = 3) buffer Check { uint boundBits; uint referenceBits; uint badKeys; uint referenceBadKeys; };
uniform int uProbeCount;

void main() {
    const int i = int(gl_GlobalInvocationID.x);
    if (i >= uProbeCount) return;
    const int width = textureSize(uProbeNew, 0).x;
    const ivec2 texel = ivec2(i % width, i / width);
    const vec3 d = abs(texelFetch(uProbeNew, texel, 0).rgb - texelFetch(uProbeReference, texel, 0).rgb);
    const float m = max(max(d.r, d.g), d.b);
    if (m > 0.0) atomicMax(boundBits, floatBitsToUint(m));
    else if (!(m == 0.0)) atomicMax(boundBits, 0x7F800000u); // NaN: +inf, never within tolerance
}
