#pragma once
// The double-precision instance of gi/lightskin/shaders/lightskin_math.glsl: the SAME source the shaders
// compile, with real = double and rvec3 = glm::dvec3 (see the rules at the top of that file).
// Private to the gi module; the public entry points are in lightskin/gi/reference/LightSkinReference.h.

#include <glm/common.hpp>
#include <glm/exponential.hpp>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace lightskin::gi::refmath {

using real = double;
using rvec2 = glm::dvec2;
using rvec3 = glm::dvec3;
using glm::abs;
using glm::acos;
using glm::atan;
using glm::clamp;
using glm::cross;
using glm::dot;
using glm::exp;
using glm::inversesqrt;
using glm::length;
using glm::log;
using glm::max;
using glm::min;
using glm::sqrt;

#define LS_CPP 1
#define LS_FN inline
#include "../shaders/lightskin_math.glsl"
#undef LS_FN
#undef LS_CPP

} // namespace lightskin::gi::refmath
