#pragma once
// The double-precision instance of gi/lightskin/shaders/val_tree_math.glsl (the source gather_tree.comp compiles),
// next to lightskin_math.glsl's in refmath. Private to the gi module.

#include "LightSkinMath.h"

#include <glm/trigonometric.hpp>

namespace lightskin::gi::refmath {

using glm::asin;
using glm::cos;

#define LS_CPP 1
#define LS_FN inline
#include "../shaders/val_tree_math.glsl"
#undef LS_FN
#undef LS_CPP

} // namespace lightskin::gi::refmath
