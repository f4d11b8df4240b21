// Light samples and shadow-casting boxes of the synthetic scene (std140 UBO, binding 0; the C++
// side in SceneRenderer.cpp fills it with the same layout).

#define MAX_LIGHT_SAMPLES 256
#define MAX_BOXES 32
const float PI = 3.14159265358979;

layout(std140, binding = 0) uniform SceneLights {
    ivec4 counts;                                  // x: light samples, y: boxes
    vec4 ambientRadiance;                          // rgb: uniform incident radiance
    vec4 samplePosition[MAX_LIGHT_SAMPLES];        // xyz world; w = 1 isotropic point, 0 one-sided patch
    vec4 sampleNormal[MAX_LIGHT_SAMPLES];          // xyz: emitting direction of a patch
    vec4 sampleIntensity[MAX_LIGHT_SAMPLES];       // rgb: radiant intensity (W/sr) along the normal
    vec4 boxRows[3 * MAX_BOXES];                   // box_T_world, rows 0..2 (xyz rotation, w translation)
    vec4 boxHalfSize[MAX_BOXES];                   // xyz half edge lengths
};

// True if the segment origin + t * direction, t in (0, 1), hits a box.
bool segmentBlocked(vec3 origin, vec3 direction) {
    for (int b = 0; b < counts.y; ++b) {
        vec3 o = vec3(dot(boxRows[3 * b].xyz, origin) + boxRows[3 * b].w,
                      dot(boxRows[3 * b + 1].xyz, origin) + boxRows[3 * b + 1].w,
                      dot(boxRows[3 * b + 2].xyz, origin) + boxRows[3 * b + 2].w);
        vec3 d = vec3(dot(boxRows[3 * b].xyz, direction), dot(boxRows[3 * b + 1].xyz, direction),
                      dot(boxRows[3 * b + 2].xyz, direction));
        vec3 h = boxHalfSize[b].xyz;
        // Slab test; a zero direction component gives +-inf, which the min/max handle.
        vec3 inverse = 1.0 / d;
        vec3 t0 = (-h - o) * inverse;
        vec3 t1 = (h - o) * inverse;
        vec3 tNear = min(t0, t1), tFar = max(t0, t1);
        float enter = max(max(tNear.x, tNear.y), tNear.z);
        float leave = min(min(tFar.x, tFar.y), tFar.z);
        if (enter <= leave && leave > 1e-4 && enter < 1.0 - 1e-4) return true;
    }
    return false;
}

// Irradiance (W/m^2) at a surface point with unit normal n from all light samples, shadowed.
vec3 directIrradiance(vec3 position, vec3 n) {
    vec3 origin = position + 1e-4 * n; // off the surface, so its own box does not shadow it
    vec3 irradiance = vec3(0.0);
    for (int i = 0; i < counts.x; ++i) {
        vec3 toLight = samplePosition[i].xyz - origin;
        float distanceSquared = dot(toLight, toLight);
        vec3 l = toLight * inversesqrt(distanceSquared);
        float cosReceiver = dot(n, l);
        if (cosReceiver <= 0.0) continue;
        float cosEmitter = samplePosition[i].w > 0.5 ? 1.0 : max(0.0, -dot(sampleNormal[i].xyz, l));
        if (cosEmitter <= 0.0) continue;
        if (segmentBlocked(origin, toLight)) continue;
        irradiance += sampleIntensity[i].rgb * (cosEmitter * cosReceiver / distanceSquared);
    }
    return irradiance;
}
