#pragma once
// `lightskin bench-lights` (apps/lightskin): see bench/src/LightsBench.cpp and docs/BENCHMARKS.md.

#include <lightskin/bench/StopRequest.h>

#include <string>
#include <vector>

namespace lightskin::bench {

struct LightsBenchOptions {
    int repeat = 10;
    std::string mesh;
    std::string out;
    /// Asked between measurements (Ctrl-C in the command): true = stop, output what was measured, marked interrupted.
    StopRequested stopRequested;
};

/// VAL generation, RSM VALs and sparse-point preparation times; prints (and optionally writes) a Markdown table.
/// Needs no current GL context (creates its own headless one); throws lightskin::Error on bad input.
void runLightsBench(const LightsBenchOptions& options);

} // namespace lightskin::bench
