#pragma once
// The heavy third-party headers most test programs include, precompiled once for all of them
// (tests/CMakeLists.txt, lightskin_test_precompiled): each accounted for 2.5-4 s of every test file's
// compile (docs/TESTING.md "Build and CI times"). Only stable library headers belong here: a header of
// ours would rebuild every test on each change.
#include <gtest/gtest.h>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>
