#pragma once
// `lightskin bench-realdepth` (apps/lightskin): see bench/src/RealDepthBench.cpp and docs/BENCHMARKS.md.

#include <string>
#include <vector>

namespace lightskin::bench {

struct RealDepthBenchOptions {
    std::string data = "tests/data";
    std::string scene = "recordings/scenes/on_real_surface.json";
    std::string out = "bench-realdepth-out";
    std::string models = "old,robust";
    std::vector<double> sinks{0.0, 0.01};
    int maxFrames = 12; ///< cap on each recording's own frame count (5, the .oni 12)
    bool maps = false;
    std::string recordings; ///< comma-separated case names; empty = all
};

/// Speckle and flicker of the indirect light on real depth (bundled recordings), old vs robust light model.
/// Needs no current GL context (creates its own headless one); throws lightskin::Error on bad input.
void runRealDepthBench(const RealDepthBenchOptions& options);

} // namespace lightskin::bench
