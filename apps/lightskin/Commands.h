#pragma once
// Subcommands of `lightskin` register themselves: each *Command.cpp file in this folder defines
//   static const lightskin::apps::CommandRegistration registration{"name", &addNameCommand};
// and addNameCommand(app, exitCode) adds a CLI11 subcommand whose callback stores the process exit
// code in `exitCode`. Failures throw lightskin::Error (printed by main, exit 1).

#include <CLI/CLI.hpp>

#include <functional>
#include <span>

namespace lightskin::apps {

using AddCommandFunction = void (*)(CLI::App& app, int& exitCode);

struct CommandRegistration {
    CommandRegistration(const char* name, AddCommandFunction add);
};

/// Adds every registered subcommand to `app`, in name order.
void addRegisteredCommands(CLI::App& app, int& exitCode);

/// The process's arguments as main() received them (argv[0] first; not owned, valid for the process's
/// lifetime), for a command that runs another program with them (ToolsForward.cpp).
void setProgramArguments(int argc, char** argv);
std::span<char* const> programArguments();

} // namespace lightskin::apps
