#version 450 core
#include "gather_cull.glsl"
// Unordered VAL culling (LightSkinSettings::stableCull = false, for measurement only): the VALs
// that gather_cull.glsl keeps are appended with an atomic counter, so their order (and, through
// float summation order, the gather sums and the image) changes from run to run at rounding level.
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Source { VirtualAreaLight source[]; };
layout(std430, binding = 3) buffer Counter { uint kept; };
layout(std430, binding = 4) writeonly buffer Destination { VirtualAreaLight destination[]; };
uniform uint uCount;
uniform uint uGroupFirst;
uniform vec4 uReceiverSphere; // centre xyz, radius w (world metres)
uniform float uInfluenceCutoff;

void main() {
    const uint i = (uGroupFirst + gl_WorkGroupID.x) * CULL_GROUP_SIZE + gl_LocalInvocationID.x;
    if (i >= uCount) return;
    const VirtualAreaLight val = source[i];
    if (!cullKeeps(val, uReceiverSphere, uInfluenceCutoff)) return;
    destination[atomicAdd(kept, 1u)] = val;
}
