#pragma once
// `lightskin bench` (apps/lightskin): see bench/src/SweepBench.cpp and docs/BENCHMARKS.md.

#include <lightskin/bench/BenchReport.h>
#include <lightskin/bench/StopRequest.h>

#include <string>
#include <vector>

namespace lightskin::bench {

struct SweepBenchOptions {
    bool quick = false;
    std::string out = "bench-out";
    std::string docs;
    std::string bunnyPath = "tests/data/stanford-bunny/bun_zipper_res4.ply";
    std::string sparse = "64,256,1024,4096,16384";
    std::string strides = "8,4,2,1";
    std::string kCache = "32,128,512";
    std::string channels = "diffuse,glossy,occlusion";
    std::string resolutions = "640x480,1280x720,1920x1080";
    std::string meshes = "20000,200000,730000";
    std::string adaptive = "off,on";
    std::string backends = "gl,cpu"; ///< backends of LightSkin to sweep: gl, cpu (gi::CpuLightSkin)
    /// LightSkinSettings::valTreeThreshold values to sweep (axis "tree"); empty = none.
    std::string trees = "0.01,0.1";
    /// Imperfect-volumes rows (resolution:points/triangle:rays/voxel:bounces); the first is the paper's.
    std::string volumes = "64:12:100:1,32:12:100:1,64:6:100:1,64:12:36:1,64:12:100:2";
    /// Multi-scale PRT rows (entry points:walks per entry:clusters:D). Their precompute (the rows'
    /// prepare time) grows with entries x walks x exit vertices: the 20k-triangle sphere's ~10k vertices make
    /// it seconds to minutes, so the default is two small rows.
    /// An optional fifth field sets the per-frame gather points (MultiscalePrtSettings::directGatherPoints,
    /// default 1024; 0 = the first bounce at every vertex).
    std::string prt = "256:8:8:4,256:8:8:0";
    /// Multi-scale PRT's precompute cache folder (empty = none: the rows' prepare time is the precompute).
    std::string prtCacheDir;
    Config defaults;
    int frames = 3;
    int truthStride = 2;
    int truthGrid = 48;
    double maxBruteInteractions = 1e10;
    double maxTruthRays = 3e8;
    int temporalFrames = 8;
    std::string temporalSparse = "256,1024,4096";
    int temporalStride = 8;
    float temporalTolerance = 0.01f; ///< metres between a tracked vertex and the G-buffer position at its pixel
    bool temporal = true;
    bool check = false;
    double tolerance = 0.05;
    std::string exportBlender;
    std::string fromJson;
    bool table1 = false;     ///< the paper's Table 1 setups instead of the sweep
    bool kinect = false;     ///< the Kinect setups instead of the sweep
    std::string tableOutput; ///< overrides the table's output WxH
    std::string tableSparse; ///< overrides the table's sparse totals
    std::string tableVals;   ///< overrides the table's VAL maps
    int tableSubset = 0;     ///< overrides the brute-force subset step
    int tableFrames = 1;
    /// Asked between measurements (Ctrl-C in the command): true = stop, output what was measured, marked interrupted.
    StopRequested stopRequested;
};

/// The speed/accuracy sweep (or --table1/--kinect, --from-json, --export-blender); writes bench.{csv,json,md} and the
/// plots to options.out. Returns the exit code (3: a --check failed). Needs no current GL context (creates its own
/// headless one); throws lightskin::Error on bad input.
int runSweepCommand(const SweepBenchOptions& options);

} // namespace lightskin::bench
