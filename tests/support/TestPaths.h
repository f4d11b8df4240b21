#pragma once
// Paths for tests, independent of the working directory.
#include <filesystem>

namespace lightskin::test {
/// The repository root (tests/data, recordings/ live below it).
std::filesystem::path sourceDir();
/// `tests/data/<relative>`; fails the test (throws) if it does not exist.
std::filesystem::path dataPath(const std::filesystem::path& relative);
/// A fresh empty folder under the build tree for this test's outputs.
std::filesystem::path scratchDir(const std::string& name);
} // namespace lightskin::test
