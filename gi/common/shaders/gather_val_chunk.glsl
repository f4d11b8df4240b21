// One chunk of K_CACHE virtual area lights as a uniform block (Listing 1 of the paper: the
// loop over K_cache VALs reads them from fast, shared memory). The block is a range of the VAL
// buffer itself (glBindBufferRange): std140 lays out an array of VirtualAreaLight (three vec4)
// exactly like the std430 buffer, so no copy is needed.
#ifndef GATHER_VAL_CHUNK_GLSL
#define GATHER_VAL_CHUNK_GLSL
#include "virtual_area_light.glsl"
#ifndef K_CACHE
#define K_CACHE 128
#endif
layout(std140, binding = 0) uniform GatherValChunk {
    VirtualAreaLight chunkVals[K_CACHE];
};
uniform int uValCount; // VALs valid in this chunk (<= K_CACHE)
#endif
