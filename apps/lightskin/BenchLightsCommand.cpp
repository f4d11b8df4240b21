// `lightskin bench-lights`: argument parsing only; the benchmark is lightskin::bench (LightsBench.h).
#include "CliSupport.h"
#include "Commands.h"
#include "ToolCommands.h"

#include <lightskin/bench/LightsBench.h>

#include <memory>
#include <string>

namespace lightskin::apps {

namespace {

void addBenchLightsCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand("bench-lights", toolDescription("bench-lights"));
    auto options = std::make_shared<bench::LightsBenchOptions>();
    command->add_option("--repeat", options->repeat, "Timed repetitions per case (median reported)")
        ->check(CLI::Range(1, 1000));
    command->add_option("--mesh", options->mesh, "OBJ mesh for sparse points (default: a 70k-triangle UV sphere)")
        ->check(CLI::ExistingFile);
    command->add_option("--out", options->out, "Also write the markdown table to this file");
    command->callback([options, &exitCode] {
        if (!options->out.empty()) checkOutputFile(options->out, {options->mesh}, "--out");
        const StopSignals stopSignals; // Ctrl-C and SIGTERM: finish the measurement, output what was measured
        options->stopRequested = [] { return StopSignals::requested(); };
        bench::runLightsBench(*options);
        exitCode = StopSignals::exitCode();
    });
}

} // namespace

static const CommandRegistration registration{"bench-lights", &addBenchLightsCommand};

} // namespace lightskin::apps
