#version 450 core
// ValOccupancyCull, pass 2: one invocation per VAL; area = 0 when the VAL lies inside the virtual
// content's depth range on its pixel's ray (margins: gi/common/include/lightskin/gi/common/ValOccupancyCull.h).
#include "virtual_area_light.glsl"

layout(local_size_x = 64) in;
layout(binding = 0) uniform sampler2D uRange; // (min z, -max z) of the virtual content; (kEmpty, kEmpty) where none
layout(std430, binding = 0) buffer Vals { VirtualAreaLight vals[]; };
layout(std430, binding = 1) readonly buffer Keys { uint pixelIndex[]; };
layout(std430, binding = 2) buffer Counter { uint culled; };
uniform uint uCount;
uniform ivec2 uSize; // width, height of the depth map = the render target
uniform mat4 uCameraFromWorld;

const float kEmpty = 1.0e30;
const float kPi = 3.14159265358979;

void main() {
    const uint i = gl_GlobalInvocationID.x;
    if (i >= uCount) return;
    const vec4 pa = vals[i].positionArea;
    if (!(pa.w > 0.0)) return;
    const uint key = pixelIndex[i];
    // Keys count image rows from the top; GL render targets from the bottom.
    const ivec2 pixel = ivec2(int(key % uint(uSize.x)), uSize.y - 1 - int(key / uint(uSize.x)));
    const vec2 range = texelFetch(uRange, pixel, 0).xy;
    if (range.x >= kEmpty) return; // no virtual content on this ray
    const float z = (uCameraFromWorld * vec4(pa.xyz, 1.0)).z;
    const float sigma = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4); // Kinect v1 axial noise, metres
    const float radius = sqrt(pa.w / kPi);
    if (z >= range.x - 3.0 * sigma && z <= -range.y + radius + 3.0 * sigma) {
        vals[i].positionArea.w = 0.0;
        atomicAdd(culled, 1u);
    }
}
