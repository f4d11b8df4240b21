// One chunk of K_CACHE virtual area lights as a uniform block (Listing 1 of the paper: the
// loop over K_cache VALs reads them from fast, shared memory). Layout per VAL: three vec4, the
// same as lightskin::gi::VirtualAreaLight: position.xyz + area, normal.xyz + pad, flux.rgb + pad.
// (To be reconciled with virtual_area_light.glsl once that lands.)
#ifndef GATHER_VAL_CHUNK_GLSL
#define GATHER_VAL_CHUNK_GLSL
#ifndef K_CACHE
#define K_CACHE 128
#endif
layout(std140, binding = 0) uniform GatherValChunk {
    vec4 valData[3 * K_CACHE];
};
uniform int uValCount; // VALs valid in this chunk (<= K_CACHE)
#endif
