#version 450 core
// Section 3.1: uPerTriangle random points per triangle with density 1/A (u1, u2 from the PCG hash
// of the point id, as the reference's sampleTriangles), normal interpolated. With scene lights
// (uLightCount > 0) each point carries its direct light: rho_d / pi * E_direct, E_direct as the
// renderer's diffuse term (render/shaders/shade.frag: intensity, smoothstep cone, cube-map shadow).
#include "volumes_inject.glsl"

layout(local_size_x = 64) in;
layout(std430, binding = 6) readonly buffer Positions { vec4 positions[]; }; // model space, metres
layout(std430, binding = 7) readonly buffer Normals { vec4 normals[]; };
layout(std430, binding = 8) readonly buffer Indices { uint indices[]; };
layout(location = 3) uniform uint uPointCount; // triangles * uPerTriangle
layout(location = 8) uniform uint uPointOffset; // of this dispatch (at most 65535 groups each)
layout(location = 4) uniform uint uPerTriangle;
layout(location = 5) uniform uint uSeed;
layout(location = 6) uniform mat4 uWorldFromModel;
layout(location = 7) uniform vec3 uAlbedo;

const int kMaxLights = 4; // gi::kMaxVolumeLights
layout(location = 9) uniform int uLightCount;
layout(location = 10) uniform vec3 uLightPosition[kMaxLights];  // 10-13, world metres
layout(location = 14) uniform vec3 uLightDirection[kMaxLights]; // 14-17, spot axis
layout(location = 18) uniform vec3 uLightIntensity[kMaxLights]; // 18-21, W/sr
layout(location = 22) uniform vec2 uLightCos[kMaxLights];       // 22-25, (cos outer, cos inner); outer < -1.5: point
layout(location = 26) uniform int uLightShadows[kMaxLights];    // 26-29, 1: look up uShadowDistance
layout(binding = 0) uniform samplerCubeArray uShadowDistance;   // metres from the light to the nearest virtual surface

// The renderer's shadow test (shade.frag shadowFactor): its bias, so both shadow the same points.
float shadowFactor(int light, vec3 position) {
    if (uLightShadows[light] == 0) return 1.0;
    const vec3 fromLight = position - uLightPosition[light];
    const float dist = length(fromLight);
    const float stored = texture(uShadowDistance, vec4(fromLight, float(light))).r;
    const float bias = 0.01 + 0.02 * dist;
    return dist - bias > stored ? 0.0 : 1.0;
}

vec3 directIrradiance(vec3 position, vec3 n) {
    vec3 e = vec3(0.0);
    for (int i = 0; i < uLightCount; ++i) {
        const vec3 toLight = uLightPosition[i] - position;
        const float d2 = max(dot(toLight, toLight), 1e-8);
        const vec3 l = toLight / sqrt(d2);
        const float cosTheta = dot(n, l);
        if (cosTheta <= 0.0) continue;
        float cone = 1.0;
        if (uLightCos[i].x > -1.5) cone = smoothstep(uLightCos[i].x, uLightCos[i].y, dot(-l, uLightDirection[i]));
        if (cone <= 0.0) continue;
        e += uLightIntensity[i] * (cone * cosTheta / d2 * shadowFactor(i, position));
    }
    return e;
}

void main() {
    const uint id = uPointOffset + gl_GlobalInvocationID.x;
    if (id >= uPointCount) return;
    const uint t = id / uPerTriangle;
    const float u1 = unitFromHash(pcgHash(uSeed ^ (2u * id)));
    const float u2 = unitFromHash(pcgHash(uSeed ^ (2u * id + 1u)));
    const float s = sqrt(u1);
    const vec3 w = vec3(1.0 - s, s * (1.0 - u2), s * u2);
    const uint i0 = indices[3u * t], i1 = indices[3u * t + 1u], i2 = indices[3u * t + 2u];
    const vec3 p = w.x * positions[i0].xyz + w.y * positions[i1].xyz + w.z * positions[i2].xyz;
    const vec3 n = w.x * normals[i0].xyz + w.y * normals[i1].xyz + w.z * normals[i2].xyz;
    const vec3 wn = mat3(uWorldFromModel) * n;
    const float len = length(wn);
    const vec3 normal = len > 0.0 ? wn / len : vec3(0.0);
    const vec3 position = (uWorldFromModel * vec4(p, 1.0)).xyz;
    const bool lit = uLightCount > 0;
#ifdef VOLUMES_MARK_OCCUPANCY
    const vec3 radiance = vec3(0.0); // the first pass only flags voxels
#else
    const vec3 radiance = lit && len > 0.0 ? uAlbedo / kPi * directIrradiance(position, normal) : vec3(0.0);
#endif
    injectPoint(position, normal, radiance, uAlbedo, lit);
}
