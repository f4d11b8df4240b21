#version 450 core
#include "gather_cull.glsl"
// Stable VAL culling, pass 1 of 3 (gather_cull.glsl): each work group of CULL_GROUP_SIZE VALs
// writes every VAL's slot among its group's kept VALs (CULL_DROPPED if culled) and its kept count.
// Two-level scan in shared memory with three barriers: 16 threads each scan a run of 16 flags,
// one thread scans the 16 run totals.
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Source { VirtualAreaLight source[]; };
layout(std430, binding = 1) writeonly buffer Slots { uint slot[]; };
layout(std430, binding = 2) writeonly buffer GroupCounts { uint groupCount[]; };
uniform uint uCount;
uniform uint uGroupFirst; // dispatches of at most 65535 work groups
uniform vec4 uReceiverSphere; // centre xyz, radius w (world metres)
uniform float uInfluenceCutoff;
shared uint scan[CULL_GROUP_SIZE]; // keep flags, then exclusive prefix within each run of 16
shared uint runOffset[16];         // run totals, then exclusive prefix over the runs

void main() {
    const uint t = gl_LocalInvocationID.x;
    const uint group = uGroupFirst + gl_WorkGroupID.x;
    const uint i = group * CULL_GROUP_SIZE + t;
    const bool keep = i < uCount && cullKeeps(source[i], uReceiverSphere, uInfluenceCutoff);
    scan[t] = keep ? 1u : 0u;
    barrier();
    if (t < 16u) {
        uint sum = 0u;
        for (uint k = 16u * t; k < 16u * t + 16u; ++k) {
            const uint f = scan[k];
            scan[k] = sum;
            sum += f;
        }
        runOffset[t] = sum;
    }
    barrier();
    if (t == 0u) {
        uint sum = 0u;
        for (uint r = 0u; r < 16u; ++r) {
            const uint c = runOffset[r];
            runOffset[r] = sum;
            sum += c;
        }
        groupCount[group] = sum;
    }
    barrier();
    if (i < uCount) slot[i] = keep ? runOffset[t / 16u] + scan[t] : CULL_DROPPED;
}
