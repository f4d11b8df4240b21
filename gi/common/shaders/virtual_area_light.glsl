// A virtual area light (VAL, LightSkin section 3.1), std430 layout matching
// lightskin::gi::VirtualAreaLight (gi/common/include/lightskin/gi/common/VirtualAreaLight.h): three vec4, 48 bytes.
// World frame, metres; area in m^2 (disc radius r = sqrt(area / pi)); normal unit, the emitting side;
// flux linear RGB radiant flux, phi = pi * L_e * area (Lambertian disc).
// Include guard: the shader library includes each file at most once, but a guard keeps hand-written
// concatenations safe too.
#ifndef LIGHTSKIN_VIRTUAL_AREA_LIGHT_GLSL
#define LIGHTSKIN_VIRTUAL_AREA_LIGHT_GLSL

struct VirtualAreaLight {
    vec4 positionArea; // xyz disc centre (world, m), w area (m^2, > 0 for a valid VAL)
    vec4 normal;       // xyz unit normal (world), w reserved (0)
    vec4 flux;         // rgb radiant flux (linear RGB), w reserved (0)
};

#endif
