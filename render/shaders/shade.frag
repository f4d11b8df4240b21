#version 450 core
// Deferred shading of the virtual content: direct light of the scene's point/spot lights with
// cube shadow maps (normalised Phong BRDF, see docs/SCENE_FORMAT.md), plus the indirect target a
// GI technique wrote, tone mapped to sRGB. Also writes the camera-frame depth for compositing.
layout(location = 0) in vec2 uv;

layout(binding = 0) uniform sampler2D gPosition;
layout(binding = 1) uniform sampler2D gNormal;
layout(binding = 2) uniform sampler2D gAlbedo;
layout(binding = 3) uniform sampler2D gSpecular;
layout(binding = 4) uniform sampler2D indirectRadiance;
layout(binding = 5) uniform samplerCubeArray shadowDistance;

const int kMaxLights = 4;
uniform int lightCount;
uniform vec3 lightPosition[kMaxLights];
uniform vec3 lightDirection[kMaxLights];
uniform vec3 lightIntensity[kMaxLights]; // W/sr = power / (4 pi)
uniform float lightCosOuter[kMaxLights]; // spot: cos(cone + falloff); -2 for point lights
uniform float lightCosInner[kMaxLights]; // spot: cos(cone)
uniform bool lightShadows[kMaxLights];

uniform vec3 cameraPosition;
uniform mat4 camera_T_world;
uniform bool includeIndirect;
uniform float exposureScale; // 2^exposureStops
uniform int debugView;       // render::DebugView

layout(location = 0) out vec4 outColour;
layout(location = 1) out float outDepth;
layout(location = 2) out vec4 outLinear; // exposureScale * radiance before clamp and encoding (NaN/inf kept)

const float kPi = 3.14159265358979;

vec3 srgbEncode(vec3 linear) {
    const vec3 c = clamp(linear, 0.0, 1.0);
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}

float shadowFactor(int light, vec3 position, vec3 normal) {
    if (!lightShadows[light]) return 1.0;
    const vec3 fromLight = position - lightPosition[light];
    const float dist = length(fromLight);
    const float stored = texture(shadowDistance, vec4(fromLight, float(light))).r;
    // Slope-scaled bias: a texel of a 90-degree face covers ~2 * dist / size metres.
    const float bias = 0.01 + 0.02 * dist;
    return dist - bias > stored ? 0.0 : 1.0;
}

void main() {
    const ivec2 pixel = ivec2(gl_FragCoord.xy);
    const vec4 position = texelFetch(gPosition, pixel, 0);
    if (position.w == 0.0) {
        outColour = vec4(0.0);
        outDepth = 0.0;
        outLinear = vec4(0.0);
        return;
    }
    const vec3 n = normalize(texelFetch(gNormal, pixel, 0).xyz);
    const vec3 albedo = texelFetch(gAlbedo, pixel, 0).rgb;
    const vec4 specular = texelFetch(gSpecular, pixel, 0);
    const vec3 v = normalize(cameraPosition - position.xyz);

    vec3 direct = vec3(0.0);
    for (int i = 0; i < lightCount; ++i) {
        const vec3 toLight = lightPosition[i] - position.xyz;
        const float d2 = max(dot(toLight, toLight), 1e-8);
        const vec3 l = toLight * inversesqrt(d2);
        const float cosTheta = dot(n, l);
        if (cosTheta <= 0.0) continue;
        float cone = 1.0;
        if (lightCosOuter[i] > -1.5) cone = smoothstep(lightCosOuter[i], lightCosInner[i], dot(-l, lightDirection[i]));
        if (cone <= 0.0) continue;
        const vec3 r = reflect(-l, n);
        const float cosGamma = max(dot(r, v), 0.0);
        const vec3 brdf = albedo / kPi + specular.rgb * (specular.a + 2.0) / (2.0 * kPi) * pow(cosGamma, specular.a);
        direct += brdf * lightIntensity[i] * cone * cosTheta / d2 * shadowFactor(i, position.xyz, n);
    }
    const vec3 indirect = texelFetch(indirectRadiance, pixel, 0).rgb;

    vec3 radiance;
    if (debugView == 1) radiance = direct;
    else if (debugView == 2) radiance = indirect;
    else radiance = direct + (includeIndirect ? indirect : vec3(0.0));

    vec3 display = srgbEncode(exposureScale * radiance);
    if (debugView == 3) display = n * 0.5 + 0.5;
    if (debugView == 4) display = srgbEncode(albedo);
    outColour = vec4(display, 1.0);
    vec3 linear = exposureScale * radiance;
    if (debugView == 3) linear = pow(display, vec3(2.2)); // debug colours: approximately their display value
    if (debugView == 4) linear = albedo;
    outLinear = vec4(linear, 1.0);
    outDepth = (camera_T_world * vec4(position.xyz, 1.0)).z;
}
