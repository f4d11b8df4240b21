// Imperfect volumes (gi/volumes/include/lightskin/gi/volumes/ImperfectVolumes.h): the grid, the L1 SH, the point
// hash and the eq. 4/5 reconstruction shared by the volumes_*.comp passes. The double-precision
// reference (gi/reference/src/ImperfectVolumesReference.cpp) is written separately from the paper.
#ifndef LIGHTSKIN_VOLUMES_COMMON_GLSL
#define LIGHTSKIN_VOLUMES_COMMON_GLSL

const float kPi = 3.14159265358979;

// Storage (gi/volumes/src/ImperfectVolumes.cpp): two dense maps of one uint per voxel, occupiedSlot
// (binding 11) and activeSlot (binding 5), hold 0 or 1 + the voxel's index in the compact arrays
// (accumulation, voxels and exitant per occupied voxel; incoming per ray-marched voxel), so the
// memory follows the surfaces, not the volume (256^3 fits llvmpipe's 128 MiB per buffer).

// One voxel after injection: mean normal (0 where the normals cancel) with w = 1 if occupied,
// mean direct exitant radiance of its emitting points, mean albedo.
struct Voxel {
    vec4 normalOccupied;
    vec4 direct;
    vec4 albedo;
};
// Incoming radiance (or visibility) as L1 SH per channel: (Y00, Y1-1, Y10, Y11).
// Uniform locations 0-2 are the grid's; each pass numbers its own from 3.
struct RgbSh {
    vec4 r;
    vec4 g;
    vec4 b;
};

layout(location = 0) uniform vec3 uGridOrigin; // minimum corner, world metres
layout(location = 1) uniform float uVoxelSize; // metres
layout(location = 2) uniform int uResolution;  // voxels per side

uint voxelCount() { return uint(uResolution) * uint(uResolution) * uint(uResolution); }
// Index of this invocation in a dispatch of 1D groups of 64 (every per-voxel pass) split into rows of
// gl_NumWorkGroups.x groups (a dispatch dimension holds at most 65535 groups: 262144 at 256^3).
uint linearIndex() { return gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u + gl_GlobalInvocationID.x; }

ivec3 voxelOf(vec3 p) { return ivec3(floor((p - uGridOrigin) / uVoxelSize)); }
bool insideGrid(ivec3 v) { return all(greaterThanEqual(v, ivec3(0))) && all(lessThan(v, ivec3(uResolution))); }
uint voxelIndex(ivec3 v) { return (uint(v.z) * uint(uResolution) + uint(v.y)) * uint(uResolution) + uint(v.x); }
ivec3 voxelFromIndex(uint i) {
    const uint n = uint(uResolution);
    return ivec3(int(i % n), int((i / n) % n), int(i / (n * n)));
}
vec3 voxelCentre(ivec3 v) { return uGridOrigin + (vec3(v) + 0.5) * uVoxelSize; }

// Real SH: Y00 = 1 / (2 sqrt(pi)), Y1m = sqrt(3 / (4 pi)) (y, z, x).
vec4 shBasis(vec3 d) { return vec4(0.28209479177, 0.48860251190 * d.y, 0.48860251190 * d.z, 0.48860251190 * d.x); }
// Projection of max(0, n . w) (Funk-Hecke): A0 = pi, A1 = 2 pi / 3.
vec4 shCosineLobe(vec3 n) { return vec4(kPi, vec3(2.0 * kPi / 3.0)) * shBasis(n); }

// PCG output hash, as lightskin::gi::reference::volumes::pcgHash.
uint pcgHash(uint value) {
    const uint state = value * 747796405u + 2891336453u;
    const uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}
float unitFromHash(uint hash) { return float(hash >> 8u) / 16777216.0; }

#endif
