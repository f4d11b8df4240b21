#version 450 core
#include "gather_cull.glsl"
// Stable VAL culling, pass 2 of 3 (gather_cull.glsl): one work group replaces the uGroups
// work-group kept counts by their exclusive prefix sums (each group's first destination index)
// and writes the total kept count. Each thread scans a contiguous run of ceil(uGroups / 256)
// counts: at most 256 loop iterations up to 16.7M VALs (llvmpipe ends a loop after ~65k; that
// would take more than 4e9 VALs).
layout(local_size_x = 256) in;
layout(std430, binding = 2) buffer GroupCounts { uint groupCount[]; }; // in: counts, out: offsets
layout(std430, binding = 3) writeonly buffer Kept { uint kept; };
uniform uint uGroups;
shared uint scan[256];

void main() {
    const uint t = gl_LocalInvocationID.x;
    const uint run = (uGroups + 255u) / 256u;
    const uint first = min(t * run, uGroups), last = min(first + run, uGroups);
    uint sum = 0u;
    for (uint g = first; g < last; ++g) sum += groupCount[g];
    scan[t] = sum;
    barrier();
    for (uint d = 1u; d < 256u; d <<= 1u) {
        const uint before = t >= d ? scan[t - d] : 0u;
        barrier();
        scan[t] += before;
        barrier();
    }
    uint offset = scan[t] - sum;
    for (uint g = first; g < last; ++g) {
        const uint c = groupCount[g];
        groupCount[g] = offset;
        offset += c;
    }
    if (t == 255u) kept = scan[t];
}
