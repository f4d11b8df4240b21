#version 450 core
// See val_occupancy_range.vert: front and back faces alike (no culling), blended with GL_MIN.
layout(location = 0) in float vDepth;
layout(location = 0) out vec2 outRange; // (min z, -max z)

void main() { outRange = vec2(vDepth, -vDepth); }
