#pragma once
// `lightskin bench-cpu` (apps/lightskin): see bench/src/CpuBench.cpp and docs/BENCHMARKS.md.

#include <string>
#include <vector>

namespace lightskin::bench {

struct CpuBenchOptions {
    int outputWidth = 640, outputHeight = 480;
    std::vector<int> sparse{1024};
    std::vector<std::string> valMaps{"160x120"};
    std::vector<int> threads{1, 2};
    std::vector<std::string> targets; ///< SIMD targets to compare ("" = the dispatched one only)
    int repeat = 5;
    double peakGflops = 0.0;
    bool gl = true;
};

/// The CPU backend (gi::CpuLightSkin) beside the GL path: stage times, interactions/s, share of the FMA peak.
/// Needs no current GL context (creates its own headless one); throws lightskin::Error on bad input.
void runCpuBench(const CpuBenchOptions& options);

} // namespace lightskin::bench
