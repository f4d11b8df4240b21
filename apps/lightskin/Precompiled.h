#pragma once
// The heavy library headers every command file includes, precompiled once per program
// (apps/CMakeLists.txt): CLI11 is header-only and with nlohmann::json and OpenCV's core took most of
// each command file's compile. Only stable library headers belong here.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>
