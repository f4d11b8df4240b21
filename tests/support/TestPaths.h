#pragma once
// Paths for tests, independent of the working directory.
#include <filesystem>
#include <string>

namespace lightskin::test {
/// The repository root (tests/data, recordings/ live below it).
std::filesystem::path sourceDir();
/// `tests/data/<relative>`; fails the test (throws) if it does not exist.
std::filesystem::path dataPath(const std::filesystem::path& relative);
/// A fresh empty folder under the build tree for this test's outputs.
std::filesystem::path scratchDir(const std::string& name);
/// The whole file as text ("" when it cannot be read).
std::string readText(const std::filesystem::path& path);
/// Runs `command` through /bin/sh and returns its exit code (-1 when it did not exit normally).
int runShell(const std::string& command);
} // namespace lightskin::test
