#pragma once
// `lightskin bench-cpu` (apps/lightskin): see bench/src/CpuBench.cpp and docs/BENCHMARKS.md.

#include <lightskin/bench/StopRequest.h>

#include <string>
#include <vector>

namespace lightskin::bench {

struct CpuBenchOptions {
    int outputWidth = 640, outputHeight = 480;
    std::vector<int> sparse{1024};
    std::vector<std::string> valMaps{"160x120"};
    std::vector<int> threads{1, 2};
    std::vector<std::string> targets; ///< SIMD targets to compare ("" = the dispatched one only)
    /// LightSkinSettings::valTreeThreshold values of the CPU rows (0 = the flat gather); rows with a cut also
    /// print their relative squared error against the flat gather's image of the same setup (0 must come first).
    std::vector<float> treeThresholds{0.0f};
    int repeat = 5;
    double peakGflops = 0.0;
    bool gl = true;
    std::string out; ///< folder for bench-cpu.json and its scaling plot ("" = print only)
    /// Asked between measurements (Ctrl-C in the command): true = stop, output what was measured, marked interrupted.
    StopRequested stopRequested;
};

/// The CPU backend (gi::CpuLightSkin) beside the GL path: stage times, interactions/s, share of the FMA peak;
/// with `out` also bench-cpu.json (BenchReport.h; wall times, one run per backend, setup and VAL map) and its plots.
/// Needs no current GL context (creates its own headless one); throws lightskin::Error on bad input.
void runCpuBench(const CpuBenchOptions& options);

} // namespace lightskin::bench
