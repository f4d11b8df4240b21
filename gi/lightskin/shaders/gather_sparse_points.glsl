// One texel per sparse point: index = y * width + x. Positions and normals in world space.
#ifndef GATHER_SPARSE_POINTS_GLSL
#define GATHER_SPARSE_POINTS_GLSL
layout(binding = 8) uniform sampler2D uPointPosition; // xyz world metres, w = Phong exponent k
layout(binding = 9) uniform sampler2D uPointNormal;   // xyz unit world normal, w = occluder radius (m)
uniform int uPointCount;

ivec2 gather_pointTexel(int index) {
    const int width = textureSize(uPointPosition, 0).x;
    return ivec2(index % width, index / width);
}
int gather_pointIndex(ivec2 texel) { return texel.y * textureSize(uPointPosition, 0).x + texel.x; }
#endif
