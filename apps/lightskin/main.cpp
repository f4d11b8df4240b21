// `lightskin`: the command-line front end of the lightskin library.
#include "Commands.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>

#include <cstdio>
#include <exception>

int main(int argc, char** argv) {
    CLI::App app{"lightskin: real-time global illumination of virtual content lit by the real room (RGB-D)"};
    app.set_version_flag("--version", std::string("lightskin ") + LIGHTSKIN_VERSION);
    app.require_subcommand(1);
    bool verbose = false, quiet = false;
    app.add_flag("-v,--verbose", verbose, "Log debug messages");
    app.add_flag("-q,--quiet", quiet, "Log warnings and errors only");
    app.parse_complete_callback([&] {
        lightskin::log::setLevel(verbose ? lightskin::log::Level::Debug
                                         : quiet ? lightskin::log::Level::Warning : lightskin::log::Level::Info);
    });

    int exitCode = 0;
    lightskin::apps::setProgramArguments(argc, argv);
    lightskin::apps::addRegisteredCommands(app, exitCode);

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& error) {
        return app.exit(error);
    } catch (const lightskin::Error& error) {
        std::fprintf(stderr, "lightskin: error: %s\n", error.what());
        return 1;
    } catch (const std::exception& error) {
        std::fprintf(stderr, "lightskin: unexpected error: %s\n", error.what());
        return 2;
    }
    return exitCode;
}
