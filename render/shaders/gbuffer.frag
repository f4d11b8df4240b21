#version 450 core
// Writes gi::GBufferView: world position (w = 1 coverage), world normal (w = 1 back face), diffuse albedo,
// specular + k.
layout(location = 0) in vec3 positionWorld;
layout(location = 1) in vec3 normalWorld;
layout(location = 2) in vec2 uv;

uniform vec3 diffuseAlbedo;
uniform vec3 specularAlbedo;
uniform float specularExponent;
uniform bool hasTexture;
layout(binding = 0) uniform sampler2D diffuseTexture; // sRGB texture: sampling returns linear values

layout(location = 0) out vec4 outPosition;
layout(location = 1) out vec4 outNormal;
layout(location = 2) out vec4 outAlbedo;
layout(location = 3) out vec4 outSpecular;

void main() {
    vec3 n = normalize(normalWorld);
    // Two-sided surfaces: the normal faces the viewer (backfaces of open meshes are visible), for the
    // direct light. The GI techniques read the facing from w: a back face is the inside of an object seen
    // through a hole in its mesh, which they leave dark (gi::GBufferView::worldNormal).
    if (!gl_FrontFacing) n = -n;
    outPosition = vec4(positionWorld, 1.0);
    outNormal = vec4(n, gl_FrontFacing ? 0.0 : 1.0);
    vec3 albedo = diffuseAlbedo;
    if (hasTexture) albedo *= texture(diffuseTexture, uv).rgb;
    outAlbedo = vec4(albedo, 1.0);
    outSpecular = vec4(specularAlbedo, specularExponent);
}
