#include "Commands.h"

#include <map>
#include <string>

namespace lightskin::apps {

namespace {
std::map<std::string, AddCommandFunction>& registry() {
    static std::map<std::string, AddCommandFunction> commands;
    return commands;
}
} // namespace

CommandRegistration::CommandRegistration(const char* name, AddCommandFunction add) { registry().emplace(name, add); }

void addRegisteredCommands(CLI::App& app, int& exitCode) {
    for (const auto& [name, add] : registry()) add(app, exitCode);
}

namespace {
std::span<char* const> arguments;
} // namespace

void setProgramArguments(int argc, char** argv) { arguments = {argv, static_cast<std::size_t>(argc)}; }

std::span<char* const> programArguments() { return arguments; }

} // namespace lightskin::apps
