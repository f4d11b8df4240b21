#version 450 core
// Self-test: sums `count` uints from `values` into `total` (one atomic per work group).
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Values { uint values[]; };
layout(std430, binding = 1) buffer Total { uint total; };
uniform uint count;
shared uint groupSum;
void main() {
    if (gl_LocalInvocationIndex == 0u) groupSum = 0u;
    barrier();
    const uint i = gl_GlobalInvocationID.x;
    if (i < count) atomicAdd(groupSum, values[i]);
    barrier();
    if (gl_LocalInvocationIndex == 0u) atomicAdd(total, groupSum);
}
