// `lightskin synth ...` and `lightskin bench* ...`: the developer tools are the separate program
// `lightskin-tools` beside this one, so that the main job need not build them (apps/CMakeLists.txt).
// These subcommands run it with this process's own arguments (execv: same process, exit code and
// output), so every documented command line works unchanged and `lightskin --help` lists them.
#include "CliSupport.h"
#include "Commands.h"
#include "ToolCommands.h"

#include <lightskin/core/Error.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <unistd.h>
#include <vector>

namespace lightskin::apps {

namespace {

[[noreturn]] void runTools(const std::string& command) {
    const std::string source = "lightskin " + command;
    std::error_code error;
    const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
    if (error)
        throw Error(source, std::nullopt, "cannot find this program's folder (/proc/self/exe): " + error.message());
    const std::string program = (self.parent_path() / LIGHTSKIN_TOOLS_PROGRAM).string();

    // argv[0] stays this program's, so the tool's --help and errors read "lightskin bench ...".
    std::vector<char*> arguments(programArguments().begin(), programArguments().end());
    arguments.push_back(nullptr);
    ThirdPartyOutputCapture::restoreDescriptorForExec();
    ::execv(program.c_str(), arguments.data());
    const int cause = errno; // execv returns only on failure
    throw Error(source, std::nullopt,
                "cannot run " + program + ": " + std::strerror(cause) +
                    (cause == ENOENT ? " (the developer tools are a program of their own: cmake --build build "
                                       "--target " LIGHTSKIN_TOOLS_PROGRAM
                                       "; scripts/build_and_test.sh builds it, the main job does not)"
                                     : ""));
}

void addToolsCommands(CLI::App& app, int& /*exitCode*/) {
    for (const ToolCommand& tool : kToolCommands) {
        const std::string name(tool.name);
        auto* command = app.add_subcommand(name, std::string(tool.description));
        command->group("Developer tools (the program " LIGHTSKIN_TOOLS_PROGRAM ", run by this one)");
        // Everything after the name belongs to the tool, --help included; the tool parses it.
        // (fallthrough off: main() turns it on for every command, which would hand --help to `lightskin`).
        command->prefix_command();
        command->allow_extras();
        command->fallthrough(false);
        command->set_help_flag();
        command->callback([name] { runTools(name); });
    }
}

} // namespace

static const CommandRegistration registration{"tools", &addToolsCommands};

} // namespace lightskin::apps
