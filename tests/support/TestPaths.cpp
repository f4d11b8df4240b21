#include "TestPaths.h"

#include <stdexcept>

namespace lightskin::test {

std::filesystem::path sourceDir() { return LIGHTSKIN_SOURCE_DIR; }

std::filesystem::path dataPath(const std::filesystem::path& relative) {
    const std::filesystem::path path = sourceDir() / "tests" / "data" / relative;
    if (!std::filesystem::exists(path)) throw std::runtime_error("test data missing: " + path.string());
    return path;
}

std::filesystem::path scratchDir(const std::string& name) {
    const std::filesystem::path path = std::filesystem::path(LIGHTSKIN_BINARY_DIR) / "test-scratch" / name;
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
    return path;
}

} // namespace lightskin::test
