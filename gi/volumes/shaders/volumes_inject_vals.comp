#version 450 core
// Section 3.2 for mixed reality: every VAL (a depth pixel of the real room, or an RSM texel of the
// virtual content) is a point with exitant radiance flux / (pi area); culled VALs (area 0) are skipped.
#include "virtual_area_light.glsl"
#include "volumes_inject.glsl"

layout(local_size_x = 64) in;
layout(std430, binding = 6) readonly buffer Vals { VirtualAreaLight vals[]; };
layout(location = 3) uniform uint uValCount;
layout(location = 4) uniform vec3 uRealAlbedo;

void main() {
    const uint i = gl_GlobalInvocationID.x;
    if (i >= uValCount) return;
    const VirtualAreaLight val = vals[i];
    if (!(val.positionArea.w > 0.0)) return;
    injectPoint(val.positionArea.xyz, normalize(val.normal.xyz), val.flux.rgb / (kPi * val.positionArea.w), uRealAlbedo,
                true);
}
