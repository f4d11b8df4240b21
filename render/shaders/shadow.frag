#version 450 core
// Stores the distance from the light to the nearest virtual surface, metres.
layout(location = 0) in vec3 positionWorld;
uniform vec3 lightPosition;
layout(location = 0) out float distanceToLight;
void main() { distanceToLight = length(positionWorld - lightPosition); }
