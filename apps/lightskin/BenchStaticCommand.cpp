// `lightskin bench-static`: argument parsing only; the benchmark is lightskin::bench (StaticBench.h).
#include "CliSupport.h"
#include "Commands.h"
#include "ToolCommands.h"

#include <lightskin/bench/StaticBench.h>

#include <limits>
#include <memory>
#include <string>

namespace lightskin::apps {

namespace {

void addBenchStaticCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand("bench-static", toolDescription("bench-static"));
    auto o = std::make_shared<bench::StaticBenchOptions>();
    command->add_option("--frames", o->frames, "Frames per stream after one warm-up frame")
        ->check(CLI::Range(1, 100000));
    command->add_option("--stride", o->stride, "VAL stride")->check(CLI::Range(1, 64));
    command->add_option("--sparse", o->sparse, "Sparse points per object")->check(CLI::Range(1, 1 << 20));
    command->add_option("--width", o->width, "Output width")->check(CLI::Range(16, 8192));
    command->add_option("--height", o->height, "Output height")->check(CLI::Range(16, 8192));
    command->add_option("--tolerances", o->tolerances, "staticTolerance values")->check(numberList(0.0, 1.0));
    command->add_option("--probe-stride", o->probeStride, "staticProbeStride of the probe modes")
        ->check(CLI::Range(1, 1024));
    command->add_flag("--diffuse", o->diffuse,
                      "Drop f_s from all materials (the tolerance mode needs the glossy channel off)");
    command->add_option("--recording", o->recording,
                        "Also run the real stream on this recording (.oni, TUM or lightskin folder)");
    command->add_option("--bunny", o->bunnyPath,
                        "Stanford bunny PLY (relative paths of the default: beside the program or the build, never the "
                        "current folder)");
    resolveShippedData(command, {{"--bunny", &o->bunnyPath, "Stanford bunny PLY"}});
    command->add_option("--seed", o->seed, "Noise seed")
        ->check(CLI::Range(std::uint64_t{0}, std::numeric_limits<std::uint64_t>::max()));
    command->callback([o, &exitCode] {
        const StopSignals stopSignals; // Ctrl-C and SIGTERM: finish the measurement, output what was measured
        o->stopRequested = [] { return StopSignals::requested(); };
        bench::runStaticBench(*o);
        exitCode = StopSignals::exitCode();
    });
}

const CommandRegistration registration{"bench-static", &addBenchStaticCommand};

} // namespace

} // namespace lightskin::apps
