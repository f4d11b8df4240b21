#version 450 core
// VALs from a depth map (ValGenerator; LightSkin section 5): one invocation per VAL-map pixel
// (every `stride`-th depth pixel in each direction). Valid pixels append one disc VAL to a packed
// buffer through an atomic counter; invalid pixels append nothing. The per-pixel math is the one
// documented in gi/common/include/lightskin/gi/common/ValGenerator.h; the double CPU reference is
// gi/reference/src/ValGeneratorReference.cpp (normals from PCL instead of this window walk).
#include "virtual_area_light.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform sampler2D depthMap;  // R32F, metres along the optical axis; <= 0 or NaN = missing
layout(binding = 1) uniform sampler2D colourMap; // RGBA8 holding sRGB-encoded values (decoded below)

layout(std430, binding = 0) writeonly buffer Vals { VirtualAreaLight vals[]; };
layout(std430, binding = 1) writeonly buffer PixelIndices { uint pixelIndex[]; };
layout(std430, binding = 2) buffer Counter { uint valCount; };

uniform ivec2 depthSize;     // depth map size, pixels
uniform ivec2 valMapSize;    // (depthSize / stride), floor
uniform int stride;          // s >= 1
uniform int windowRadius;    // R >= 1: gradients averaged over the (2R+1)^2 window
uniform vec4 intrinsics;     // fx, fy, cx, cy (pixels; fy may be negative)
uniform mat4 world_T_camera; // rigid
uniform float exposure;      // radiance = exposure * linear RGB
uniform float maxDepthChange; // relative step |z_a - z_b| / z_centre between adjacent samples
uniform float minCosine;     // clamp of cos(normal, view ray) in the area
uniform float minDepth;      // valid: minDepth < z <= maxDepth (NaN and +-inf fail both)
uniform float maxDepth;
uniform uint capacity;

const float kPi = 3.14159265358979;

#ifdef TILE_SIZE
// The work group's depth footprint (8 VAL pixels * stride + the normal window) staged in shared
// memory: each depth texel is fetched once per group instead of ~70 times (llvmpipe fetches are slow).
shared float tile[TILE_SIZE * TILE_SIZE];
ivec2 tileOrigin;
float depthAt(ivec2 p) {
    const ivec2 q = p - tileOrigin;
    return tile[q.y * TILE_SIZE + q.x];
}
#else
float depthAt(ivec2 p) { return texelFetch(depthMap, p, 0).r; }
#endif
// Written so that NaN fails (every comparison with NaN is false).
bool validDepth(float z) { return z > minDepth && z <= maxDepth; }
vec3 backProject(vec2 p, float z) {
    return vec3((p.x - intrinsics.z) * z / intrinsics.x, (p.y - intrinsics.w) * z / intrinsics.y, z);
}
vec3 backProject(ivec2 p, float z) { return backProject(vec2(p), z); }
// IEC 61966-2-1 decode, exact formula (llvmpipe's sRGB texture decode is off by up to 2.5 % near black).
vec3 srgbToLinear(vec3 c) {
    return mix(pow((c + 0.055) / 1.055, vec3(2.4)), c / 12.92, lessThanEqual(c, vec3(0.04045)));
}

void main() {
    const ivec2 valPixel = ivec2(gl_GlobalInvocationID.xy);
    const int R = windowRadius;
#ifdef TILE_SIZE
    tileOrigin = ivec2(gl_WorkGroupID.xy) * 8 * stride + ivec2(stride / 2 - R);
    for (int i = int(gl_LocalInvocationIndex); i < TILE_SIZE * TILE_SIZE; i += 64) {
        const ivec2 p = tileOrigin + ivec2(i % TILE_SIZE, i / TILE_SIZE);
        tile[i] = all(greaterThanEqual(p, ivec2(0))) && all(lessThan(p, depthSize)) ? texelFetch(depthMap, p, 0).r : 0.0;
    }
    barrier();
#endif
    if (any(greaterThanEqual(valPixel, valMapSize))) return;
    const ivec2 c = valPixel * stride + ivec2(stride / 2); // the depth pixel this VAL samples
    if (any(lessThan(c - ivec2(R), ivec2(0))) || any(greaterThanEqual(c + ivec2(R), depthSize))) return;

    const float zc = depthAt(c);
    if (!validDepth(zc)) return;
    const float maxStep = maxDepthChange * zc;

    // Edge test (see ValGenerator.h): every sample on the centre cross and on the window border
    // must be valid and continuous with its neighbour along the walk.
    const ivec2 arms[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
    for (int a = 0; a < 4; ++a) {
        float previous = zc;
        for (int k = 1; k <= R; ++k) {
            const float z = depthAt(c + arms[a] * k);
            if (!validDepth(z) || abs(z - previous) > maxStep) return;
            previous = z;
        }
    }
    // Border walk + 3D gradient sums (PCL AVERAGE_3D_GRADIENT telescoped to the window sides).
    vec3 gx = vec3(0.0), gy = vec3(0.0);
    float prevL = depthAt(c + ivec2(-R, -R)), prevR = depthAt(c + ivec2(R, -R));
    float prevT = depthAt(c + ivec2(-R, -R)), prevB = depthAt(c + ivec2(-R, R));
    for (int d = -R; d <= R; ++d) {
        const ivec2 pl = c + ivec2(-R, d), pr = c + ivec2(R, d), pt = c + ivec2(d, -R), pb = c + ivec2(d, R);
        const float zl = depthAt(pl), zr = depthAt(pr), zt = depthAt(pt), zb = depthAt(pb);
        if (!validDepth(zl) || !validDepth(zr) || !validDepth(zt) || !validDepth(zb)) return;
        if (abs(zl - prevL) > maxStep || abs(zr - prevR) > maxStep || abs(zt - prevT) > maxStep ||
            abs(zb - prevB) > maxStep)
            return;
        prevL = zl; prevR = zr; prevT = zt; prevB = zb;
        gx += backProject(pr, zr) - backProject(pl, zl);
        gy += backProject(pb, zb) - backProject(pt, zt);
    }
    vec3 n = cross(gy, gx);
    const float nLength = length(n);
    if (!(nLength > 0.0) || isinf(nLength)) return;
    n /= nLength;
    // Position at the block centre (i*s + (s-1)/2): for even s no pixel sits there, so the depth is
    // the mean of the central 2x2 pixels (all valid and continuous with z(c)); this removes the
    // half-pixel offset that would bias the area of tilted surfaces by ~2 * 0.5 px * tan(theta) / f.
    float zBlock = zc;
    if (stride % 2 == 0) {
        const float z00 = depthAt(c + ivec2(-1, -1)), z10 = depthAt(c + ivec2(0, -1)), z01 = depthAt(c + ivec2(-1, 0));
        if (!validDepth(z00) || !validDepth(z10) || !validDepth(z01) || abs(z00 - zc) > 2.0 * maxStep ||
            abs(z10 - zc) > maxStep || abs(z01 - zc) > maxStep)
            return;
        zBlock = 0.25 * (z00 + z10 + z01 + zc);
    }
    const vec3 p = backProject(vec2(valPixel * stride) + 0.5 * float(stride - 1), zBlock);
    const vec3 ray = normalize(p);
    if (dot(n, ray) > 0.0) n = -n; // orient toward the camera

    // Area (ValGenerator.h): footprint * cos(alpha) / max(cos(theta), minCosine).
    const float footprint = (float(stride) * zBlock / intrinsics.x) * (float(stride) * zBlock / abs(intrinsics.y));
    const float cosAlpha = ray.z;
    const float cosTheta = max(-dot(n, ray), minCosine);
    const float area = footprint * cosAlpha / cosTheta;

    // Mean linear colour of the s x s block the VAL stands for.
    const ivec2 blockStart = valPixel * stride;
    vec3 colour = vec3(0.0);
    for (int y = 0; y < stride; ++y)
        for (int x = 0; x < stride; ++x) colour += srgbToLinear(texelFetch(colourMap, blockStart + ivec2(x, y), 0).rgb);
    colour /= float(stride * stride);

    const uint index = atomicAdd(valCount, 1u);
    if (index >= capacity) return;
    VirtualAreaLight val;
    val.positionArea = vec4((world_T_camera * vec4(p, 1.0)).xyz, area);
    val.normal = vec4(normalize(mat3(world_T_camera) * n), 0.0);
    val.flux = vec4(kPi * exposure * colour * area, 0.0);
    vals[index] = val;
    pixelIndex[index] = uint(c.y * depthSize.x + c.x);
}
