// `lightskin`: the command-line front end of the lightskin library. The rules every subcommand
// follows (options, output folders, failures, exit codes) are in docs/CLI.md.
#include "CliSupport.h"
#include "Commands.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <string_view>

namespace {

/// Exit codes (docs/CLI.md): 0 done, 1 failed (bad input or a run-time failure; what was written is
/// kept and said), 2 internal error, 3 done with losses (command-specific), 64 bad command line.
constexpr int kExitFailed = 1, kExitInternal = 2, kExitUsage = 64;

/// nlohmann-json's message without its "[json.exception.parse_error.101] " prefix.
std::string withoutJsonPrefix(const std::string& message) {
    const std::size_t end = message.find("] ");
    return message.starts_with("[json.exception") && end != std::string::npos ? message.substr(end + 2) : message;
}

/// The first argument that is no option of the main program, or nullptr.
const char* firstCommandWord(int argc, char** argv) {
    for (int i = 1; i < argc; ++i)
        if (argv[i][0] != '-') return argv[i];
    return nullptr;
}

} // namespace

int main(int argc, char** argv) {
    const lightskin::apps::ThirdPartyOutputCapture capture; // first: before anything prints or logs

    CLI::App app{"lightskin: real-time global illumination of virtual content lit by the real room (RGB-D)"};
    app.set_version_flag("--version", std::string("lightskin ") + LIGHTSKIN_VERSION);
    app.require_subcommand(1);
    // Subcommands pass options they do not know (-q, -v) up to here: global options work anywhere.
    app.fallthrough();
    // Every option shows its default the same way in --help ("--out TEXT=replay-out").
    app.option_defaults()->always_capture_default();
    bool verbose = false, quiet = false;
    app.add_flag("-v,--verbose", verbose, "Log debug messages (also what libraries print: libpng, OpenCV, ...)");
    app.add_flag("-q,--quiet", quiet, "Log warnings and errors only");
    // Runs once every option of the command is parsed and validated, before the command's callback.
    app.parse_complete_callback([&] {
        lightskin::log::setLevel(verbose ? lightskin::log::Level::Debug
                                 : quiet ? lightskin::log::Level::Warning
                                         : lightskin::log::Level::Info);
        lightskin::apps::setProgressWanted(!quiet);
        // For tests of the command line (tests/apps/CliFuzzTest.cpp): stop once the values are checked.
        // (A forwarded tool command is checked by lightskin-tools, which this program runs.)
        bool forwarded = false;
        for (const CLI::App* command : app.get_subcommands()) forwarded = forwarded || command->get_prefix_command();
        if (std::getenv("LIGHTSKIN_CHECK_ARGUMENTS_ONLY") != nullptr && !forwarded) throw CLI::Success();
    });

    int exitCode = 0;
    lightskin::apps::setProgramArguments(argc, argv);
    lightskin::apps::addRegisteredCommands(app, exitCode);

    if (const char* word = firstCommandWord(argc, argv); word != nullptr) {
        std::string names;
        bool known = false;
        for (const CLI::App* command : app.get_subcommands({})) {
            names += (names.empty() ? "" : ", ") + command->get_name();
            known = known || command->get_name() == word;
        }
        if (!known) {
            std::fprintf(stderr, "lightskin: error: unknown command '%s'; the commands are: %s\n", word, names.c_str());
            return kExitUsage;
        }
    }

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& error) {
        if (error.get_exit_code() == 0) return app.exit(error); // --help, --version
        const CLI::App* command = &app;
        for (const CLI::App* sub : app.get_subcommands()) command = sub;
        std::fprintf(stderr, "lightskin%s%s: error: %s (see --help)\n", command == &app ? "" : " ",
                     command == &app ? "" : command->get_name().c_str(), error.what());
        return kExitUsage;
    } catch (const lightskin::Error& error) {
        std::fprintf(stderr, "lightskin: error: %s\n", error.what());
        return kExitFailed;
    } catch (const std::filesystem::filesystem_error& error) {
        // Names the path and the cause ("Permission denied"), like lightskin::Error.
        std::fprintf(stderr, "lightskin: error: %s: %s\n", error.path1().string().c_str(),
                     error.code().message().c_str());
        return kExitFailed;
    } catch (const nlohmann::json::exception& error) {
        // A JSON file's error that its reader did not name the file for: the cause, without the
        // library's "[json.exception...]" prefix.
        std::fprintf(stderr, "lightskin: error: cannot read a JSON file: %s\n",
                     withoutJsonPrefix(error.what()).c_str());
        return kExitFailed;
    } catch (const cv::Exception& error) {
        std::fprintf(stderr, "lightskin: error: OpenCV cannot do it: %s\n", error.err.c_str());
        return kExitFailed;
    } catch (const std::exception& error) {
        std::fprintf(stderr, "lightskin: internal error: %s\n", error.what());
        return kExitInternal;
    }
    return exitCode;
}
