#pragma once
// `lightskin bench-gather` (apps/lightskin): see bench/src/GatherBench.cpp and docs/BENCHMARKS.md.

#include <lightskin/bench/StopRequest.h>

#include <string>
#include <vector>

namespace lightskin::bench {

struct GatherBenchOptions {
    int outputWidth = 320, outputHeight = 240;
    std::vector<int> sparse{1024};
    std::vector<std::string> valMaps{"160x120"};
    std::vector<int> kCache{128};
    int repeat = 3;
    bool brute = true;
    bool compute = false;
    std::string out; ///< folder for bench-gather.json and its scaling plot ("" = print only)
    /// LightSkinSettings::valTreeThreshold values (`--tree`); 0 = the flat gather.
    std::vector<float> treeThresholds{0.0f};
    /// Only the "diffuse" setup (`--diffuse-only`): the one compared with the brute force.
    bool diffuseOnly = false;
    /// With a threshold > 0, also the BVH over the same VALs beside the VAL map's quadtree
    /// (`--tree-bvh`; without it the VAL map's pixel keys give the quadtree only).
    bool treeBvh = false;
    /// > 0 (`--brute-subset N`): the brute force on N covered pixels drawn at random (fixed seed)
    /// instead of all of them: its time scaled to all covered pixels, and every row's error on those
    /// pixels (with its sampling error); for sizes where the full brute force would take hours.
    int bruteSubset = 0;
    /// `--near-field`: guard G12 on (LightSkinSettings/BruteForceSettings::nearFieldArea, off by default):
    /// the cost of near-field VALs as areas, run against the default.
    bool nearField = false;
    /// Asked between measurements (Ctrl-C in the command): true = stop, output what was measured, marked interrupted.
    StopRequested stopRequested;
};

/// LightSkin stage times (GL timer queries) per setup, speed-up over the brute force and its error; prints them and,
/// with `out`, writes them as bench-gather.json (BenchReport.h; one run per setup and VAL map) with its plots. Needs no
/// current GL context (creates its own headless one); throws lightskin::Error on bad input.
void runGatherBench(const GatherBenchOptions& options);

} // namespace lightskin::bench
