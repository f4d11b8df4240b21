#version 450 core
// Static content, tolerance mode: sums the per-work-group bounds of gather_static_bound.comp
// (one work group, strided loop: < 65k iterations per thread up to 16M partials).
layout(local_size_x = 256) in;
layout(std430, binding = 2) readonly buffer Partials { float partials[]; };
layout(std430, binding = 3) buffer Check { float bound; uint referenceBits; uint badKeys; uint referenceBadKeys; };
uniform uint uPartialCount;
shared float partial[256];

void main() {
    const uint t = gl_LocalInvocationID.x;
    float sum = 0.0;
    for (uint i = t; i < uPartialCount; i += 256u) sum += partials[i];
    partial[t] = sum;
    barrier();
    for (uint stride = 128u; stride > 0u; stride >>= 1u) {
        if (t < stride) partial[t] += partial[t + stride];
        barrier();
    }
    if (t == 0u) bound = partial[0];
}
