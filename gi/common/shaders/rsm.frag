#version 450 core
// RSM targets: world position (w = 1 where covered), normal turned toward the light, diffuse albedo.
in vec3 worldPosition;
in vec3 worldNormal;
uniform vec3 lightPosition;
uniform vec3 diffuseAlbedo;
layout(location = 0) out vec4 outPosition;
layout(location = 1) out vec4 outNormal;
layout(location = 2) out vec4 outAlbedo;
void main() {
    vec3 n = worldNormal;
    const float nLength = length(n);
    n = nLength > 0.0 ? n / nLength : vec3(0.0, 0.0, 1.0);
    if (dot(n, lightPosition - worldPosition) < 0.0) n = -n;
    outPosition = vec4(worldPosition, 1.0);
    outNormal = vec4(n, 0.0);
    outAlbedo = vec4(diffuseAlbedo, 1.0);
}
