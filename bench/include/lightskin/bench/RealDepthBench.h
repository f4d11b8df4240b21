#pragma once
// `lightskin bench-realdepth` (apps/lightskin): see bench/src/RealDepthBench.cpp and docs/BENCHMARKS.md.

#include <lightskin/bench/StopRequest.h>

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
    /// > 0: at this many bunny pixels of each case's first frame (evenly spaced over its covered pixels, the
    /// same for every normal rule) the Embree truth with visibility (gi::RayTracedGroundTruth, 4 x 8 cells per
    /// VAL) is written to <out>/images/<case>_truth.csv with the pixel's G-buffer position and normal.
    int truthReceivers = 0;
    /// "u,v;u,v...": pixels added to those (16 x 32 cells per VAL, for single contact pixels).
    std::string truthPixels;
    /// Asked between measurements (Ctrl-C in the command): true = stop, output what was measured, marked interrupted.
    StopRequested stopRequested;
};

/// Speckle and flicker of the indirect light on real depth (bundled recordings), old vs robust light model.
/// Needs no current GL context (creates its own headless one); throws lightskin::Error on bad input.
void runRealDepthBench(const RealDepthBenchOptions& options);

} // namespace lightskin::bench
