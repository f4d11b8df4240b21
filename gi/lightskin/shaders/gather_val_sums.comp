#version 450 core
#include "virtual_area_light.glsl"
// Sums over all valid VALs (area > 0) for the eps_l terms of eq. 7, folded into the
// renormalisation analytically: sum_j (eps_l + w_j) l_j = sum_j w_j l_j + eps_l sum_j l_j, etc.
// Folding keeps eq. 7 exact while the gather loop skips eps_l, and makes the averaged positions
// independent of which VALs the adaptive mode culled. One work group, strided loop (each thread
// < 65k iterations up to 16M VALs), shared-memory reduction.
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Source { VirtualAreaLight source[]; };
layout(std430, binding = 3) writeonly buffer Sums { vec4 sums[2]; }; // (sum l, sum r^2), (sum l^2, count)
uniform uint uCount;
shared vec4 partialA[256];
shared vec4 partialB[256];

void main() {
    const uint t = gl_LocalInvocationID.x;
    vec4 a = vec4(0.0), b = vec4(0.0);
    for (uint i = t; i < uCount; i += 256u) {
        const vec4 p = source[i].positionArea;
        if (p.w > 0.0) {
            a += vec4(p.xyz, p.w / 3.14159265358979);
            b += vec4(p.xyz * p.xyz, 1.0);
        }
    }
    partialA[t] = a;
    partialB[t] = b;
    barrier();
    for (uint stride = 128u; stride > 0u; stride >>= 1u) {
        if (t < stride) {
            partialA[t] += partialA[t + stride];
            partialB[t] += partialB[t + stride];
        }
        barrier();
    }
    if (t == 0u) {
        sums[0] = partialA[0];
        sums[1] = partialB[0];
    }
}
