#version 450 core
#include "gather_cull.glsl"
// Stable VAL culling, pass 1 of 3 (gather_cull.glsl): each work group of CULL_GROUP_SIZE VALs
// writes every VAL's slot among its group's kept VALs (CULL_DROPPED if culled) and its kept count.
// Inclusive Hillis-Steele scan in shared memory (8 steps for 256).
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Source { VirtualAreaLight source[]; };
layout(std430, binding = 1) writeonly buffer Slots { uint slot[]; };
layout(std430, binding = 2) writeonly buffer GroupCounts { uint groupCount[]; };
uniform uint uCount;
uniform uint uGroupFirst; // dispatches of at most 65535 work groups
uniform vec4 uReceiverSphere; // centre xyz, radius w (world metres)
uniform float uInfluenceCutoff;
shared uint scan[CULL_GROUP_SIZE];

void main() {
    const uint t = gl_LocalInvocationID.x;
    const uint group = uGroupFirst + gl_WorkGroupID.x;
    const uint i = group * CULL_GROUP_SIZE + t;
    const bool keep = i < uCount && cullKeeps(source[i], uReceiverSphere, uInfluenceCutoff);
    scan[t] = keep ? 1u : 0u;
    barrier();
    for (uint d = 1u; d < CULL_GROUP_SIZE; d <<= 1u) {
        const uint before = t >= d ? scan[t - d] : 0u;
        barrier();
        scan[t] += before;
        barrier();
    }
    if (i < uCount) slot[i] = keep ? scan[t] - 1u : CULL_DROPPED;
    if (t == CULL_GROUP_SIZE - 1u) groupCount[group] = scan[t];
}
