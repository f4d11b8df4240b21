#include "TestPaths.h"

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include <sys/wait.h>

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

std::string readText(const std::filesystem::path& path) {
    std::ifstream file(path);
    return {std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
}

int runShell(const std::string& command) {
    const int status = std::system(command.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

} // namespace lightskin::test
