#version 450 core
// Section 3.4 per G-buffer pixel: rho_d / pi * E (eq. 4/5) into the technique's target, or the
// ambient occlusion E / pi (VOLUMES_VISIBILITY); 0 where no virtual content covers the pixel and on a
// back face (normal w = 1: the object's inside seen through a hole in its mesh, dark in the ray-traced
// truth; why 0: gi::GBufferView::worldNormal, as LightSkin and the brute force).
#include "volumes_common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0) uniform sampler2D uPosition; // xyz world, w = 1 where covered
layout(binding = 1) uniform sampler2D uNormal;
layout(binding = 2) uniform sampler2D uAlbedo;
layout(rgba32f, binding = 0) uniform writeonly image2D uTarget;
layout(std430, binding = 3) readonly buffer Incoming { RgbSh incoming[]; };
layout(std430, binding = 5) readonly buffer ActiveSlot { uint activeSlot[]; };
layout(std430, binding = 11) readonly buffer OccupiedSlot { uint occupiedSlot[]; };
#include "volumes_irradiance.glsl"
layout(location = 3) uniform ivec2 uSize;

void main() {
    const ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, uSize))) return;
    const vec4 position = texelFetch(uPosition, pixel, 0);
    const vec4 normal = texelFetch(uNormal, pixel, 0);
    const vec3 n = normal.xyz;
    vec3 result = vec3(0.0);
    if (position.w > 0.0 && normal.w <= 0.5 && dot(n, n) > 0.0) {
        const vec3 e = reconstructIrradiance(position.xyz, normalize(n));
#ifdef VOLUMES_VISIBILITY
        result = vec3(e.r / kPi);
#else
        result = texelFetch(uAlbedo, pixel, 0).rgb / kPi * e;
#endif
    }
    imageStore(uTarget, pixel, vec4(result, 0.0));
}
