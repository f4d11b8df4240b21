#pragma once
// The heavy library headers every command file includes, precompiled once per program
// (apps/CMakeLists.txt): parsing CLI11 (header-only), nlohmann::json, OpenCV's core and the standard
// library was a third of a command file's compile (docs/TESTING.md "Build and CI times"). Only stable
// library headers belong here: a header of ours would rebuild every command on each change.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>
