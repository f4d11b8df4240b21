// `lightskin bench-cull`: argument parsing only; the benchmark is lightskin::bench (CullBench.h).
#include "CliSupport.h"
#include "Commands.h"
#include "ToolCommands.h"

#include <lightskin/bench/CullBench.h>
#include <lightskin/bench/OptionLists.h>
#include <lightskin/core/Error.h>

#include <memory>
#include <string>
#include <vector>

namespace lightskin::apps {

namespace {

void addBenchCullCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand("bench-cull", toolDescription("bench-cull"));
    auto options = std::make_shared<bench::CullBenchOptions>();
    auto counts = std::make_shared<std::string>("16384,65536,524288");
    command->add_option("--vals", *counts, "Comma-separated VAL counts")->check(integerList(1, 16 * 1024 * 1024));
    command->add_option("--repeat", options->repeat, "Frames per variant (the minimum upload stage time is reported)")
        ->check(CLI::Range(1, 1000));
    command->callback([=, &exitCode] {
        // --vals is checked by the parser (integerList): every item converts.
        options->counts =
            bench::splitList<std::uint32_t>(*counts, [](const std::string& s) { return std::uint32_t(std::stoul(s)); });
        const StopSignals stopSignals; // Ctrl-C and SIGTERM: finish the measurement, output what was measured
        options->stopRequested = [] { return StopSignals::requested(); };
        bench::runCullBench(*options);
        exitCode = StopSignals::exitCode();
    });
}

} // namespace

static const CommandRegistration registration{"bench-cull", &addBenchCullCommand};

} // namespace lightskin::apps
