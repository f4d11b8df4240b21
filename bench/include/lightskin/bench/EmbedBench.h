#pragma once
// `lightskin bench-embed` (apps/lightskin): see bench/src/EmbedBench.cpp and docs/BENCHMARKS.md.

#include <lightskin/bench/StopRequest.h>

#include <string>
#include <vector>

namespace lightskin::bench {

struct EmbedBenchOptions {
    std::string recording = "recordings/synth-orbit", scene = "recordings/scenes/orbit.json";
    int frames = 10, warmUp = 4;
    std::vector<double> budgets{400.0, 150.0, 60.0};
    /// Asked between measurements (Ctrl-C in the command): true = stop, output what was measured, marked interrupted.
    StopRequested stopRequested;
};

/// mr::Session on a recording: per-frame cost and the frame budget; returns the exit code.
/// Needs no current GL context (creates its own headless one); throws lightskin::Error on bad input.
int runEmbedBench(const EmbedBenchOptions& options);

} // namespace lightskin::bench
