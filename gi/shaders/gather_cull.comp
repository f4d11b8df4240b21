#version 450 core
#include "virtual_area_light.glsl"
// Adaptive mode: copies the VALs that can reach a receiver into the technique's own buffer.
// Dropped: invalid (area <= 0 or NaN), receivers' bounding sphere wholly behind the VAL's plane
// (exactly zero contribution), and an irradiance upper bound below uInfluenceCutoff.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Source { VirtualAreaLight source[]; };
layout(std430, binding = 1) writeonly buffer Destination { VirtualAreaLight destination[]; };
layout(std430, binding = 2) buffer Counter { uint kept; };
uniform uint uCount;
uniform vec4 uReceiverSphere; // centre xyz, radius w (world metres)
uniform float uInfluenceCutoff;

void main() {
    const uint i = gl_GlobalInvocationID.x;
    if (i >= uCount) return;
    const VirtualAreaLight val = source[i];
    const vec4 a = val.positionArea;
    const vec4 b = val.normal;
    const vec4 f = val.flux;
    if (!(a.w > 0.0)) return;
    const vec3 toCentre = uReceiverSphere.xyz - a.xyz;
    if (dot(b.xyz, toCentre) < -uReceiverSphere.w) return; // sphere behind the emitting side
    const float dMin = max(length(toCentre) - uReceiverSphere.w, 0.0);
    const float r2 = a.w / 3.14159265;
    const float bound = max(max(f.r, f.g), f.b) / (3.14159265 * (r2 + dMin * dMin)); // >= M w cos
    if (bound < uInfluenceCutoff) return;
    const uint slot = atomicAdd(kept, 1u);
    destination[slot] = val;
}
