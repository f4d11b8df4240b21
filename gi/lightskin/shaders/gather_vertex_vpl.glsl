// Per-vertex averaged VPLs (eq. 13), world space, written by gather_interpolate.comp.
#ifndef GATHER_VERTEX_VPL_GLSL
#define GATHER_VERTEX_VPL_GLSL
struct VertexVpl {
    vec4 diffuse;         // L'''_d.rgb, rbar^2_d
    vec4 diffusePosition; // l'''_d.xyz, S_o radius (guard G9; 0 without it)
    vec4 glossy;          // L'''_s.rgb, rbar^2_s
    vec4 glossyPosition;  // l'''_s.xyz, G10 diffuse irradiance cap (W/m^2, < 0: none)
};
#endif
