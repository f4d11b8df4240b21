#pragma once
// `lightskin bench-static` (apps/lightskin): see bench/src/StaticBench.cpp and docs/BENCHMARKS.md.

#include <lightskin/bench/StopRequest.h>

#include <cstdint>
#include <string>
#include <vector>

namespace lightskin::bench {

struct StaticBenchOptions {
    int frames = 24;
    int stride = 4;
    int sparse = 1024;
    int width = 640, height = 480;
    std::string tolerances = "0.01,0.03,0.1";
    int probeStride = 16;
    bool diffuse = false;
    std::string recording;
    std::string bunnyPath = "tests/data/stanford-bunny/bun_zipper_res4.ply";
    std::uint64_t seed = 1;
    /// Asked between measurements (Ctrl-C in the command): true = stop, output what was measured, marked interrupted.
    StopRequested stopRequested;
};

/// Adaptive mode on static content: reuse against full recomputation on still frames.
/// Needs no current GL context (creates its own headless one); throws lightskin::Error on bad input.
void runStaticBench(const StaticBenchOptions& options);

} // namespace lightskin::bench
