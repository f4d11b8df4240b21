// `lightskin bench-static`: argument parsing only; the benchmark is lightskin::bench (StaticBench.h).
#include "Commands.h"

#include <lightskin/bench/StaticBench.h>

#include <memory>
#include <string>

namespace lightskin::apps {

namespace {

void addBenchStaticCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand(
        "bench-static",
        "Adaptive mode, static content: reuse vs full recomputation on still frames (exact, Kinect noise, real)");
    auto o = std::make_shared<bench::StaticBenchOptions>();
    command->add_option("--frames", o->frames, "Frames per stream after one warm-up frame (default 24)");
    command->add_option("--stride", o->stride, "VAL stride (default 4)");
    command->add_option("--sparse", o->sparse, "Sparse points per object (default 1024)");
    command->add_option("--width", o->width, "Output width (default 640)");
    command->add_option("--height", o->height, "Output height (default 480)");
    command->add_option("--tolerances", o->tolerances, "staticTolerance values (default 0.01,0.03,0.1)");
    command->add_option("--probe-stride", o->probeStride, "staticProbeStride of the probe modes (default 16)");
    command->add_flag("--diffuse", o->diffuse,
                      "Drop f_s from all materials (the tolerance mode needs the glossy channel off)");
    command->add_option("--recording", o->recording,
                        "Also run the real stream on this recording (.oni, TUM or lightskin folder)");
    command->add_option("--bunny", o->bunnyPath, "Stanford bunny PLY");
    command->add_option("--seed", o->seed, "Noise seed");
    command->callback([o, &exitCode] {
        bench::runStaticBench(*o);
        exitCode = 0;
    });
}

const CommandRegistration registration{"bench-static", &addBenchStaticCommand};

} // namespace

} // namespace lightskin::apps
