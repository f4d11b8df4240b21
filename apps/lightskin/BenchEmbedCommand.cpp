// `lightskin bench-embed`: argument parsing only; the benchmark is lightskin::bench (EmbedBench.h).
#include "CliSupport.h"
#include "Commands.h"
#include "ToolCommands.h"

#include <lightskin/bench/EmbedBench.h>
#include <lightskin/core/Error.h>

#include <memory>
#include <string>

namespace lightskin::apps {

namespace {

void addBenchEmbedCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand("bench-embed", toolDescription("bench-embed"));
    auto o = std::make_shared<bench::EmbedBenchOptions>();
    command->add_option(
        "--recording", o->recording,
        "Recording (relative paths of the default: beside the program or the build, never the current folder)");
    command->add_option(
        "--scene", o->scene,
        "Scene file (relative paths of the default: beside the program or the build, never the current folder)");
    resolveShippedData(command, {{"--recording", &o->recording, "sample recording"}, {"--scene", &o->scene, "scene"}});
    command->add_option("--frames", o->frames, "Frames per run")->check(CLI::Range(1, 100000));
    command->add_option("--warm-up", o->warmUp, "Budget runs: frames before the statistics")
        ->check(CLI::Range(0, 100000));
    command->add_option("--budgets", o->budgets, "Budgets in ms, one run each")->check(finiteIn(0.001, 1e6));
    command->callback([o, &exitCode] {
        if (o->frames < 1 || o->warmUp < 0 || o->warmUp >= o->frames)
            throw Error("--frames/--warm-up", std::nullopt, "need frames >= 1 and 0 <= warm-up < frames");
        const StopSignals stopSignals; // Ctrl-C and SIGTERM: finish the measurement, output what was measured
        o->stopRequested = [] { return StopSignals::requested(); };
        const int code = bench::runEmbedBench(*o);
        exitCode = StopSignals::requested() ? StopSignals::exitCode() : code;
    });
}

} // namespace

static const CommandRegistration registration{"bench-embed", &addBenchEmbedCommand};

} // namespace lightskin::apps
