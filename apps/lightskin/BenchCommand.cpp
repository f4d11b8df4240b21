// `lightskin bench`: argument parsing only; the benchmark is lightskin::bench (SweepBench.h).
#include "CliSupport.h"
#include "Commands.h"
#include "ToolCommands.h"

#include <lightskin/bench/SweepBench.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

namespace lightskin::apps {

namespace {

void addBenchCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand("bench", toolDescription("bench"));
    auto o = std::make_shared<bench::SweepBenchOptions>();
    command->add_flag("--quick", o->quick,
                      "CI smoke run (< 2 min): small sweep, checks that error falls with sparse points and VALs");
    command->add_option("--out", o->out, "Output folder for bench.csv/json/png/md");
    command->add_option("--docs", o->docs,
                        "Regenerate the section between the lightskin-bench markers in this Markdown file");
    command->add_option("--bunny", o->bunnyPath,
                        "Stanford bunny PLY (relative paths of the default: beside the program or the build, never the "
                        "current folder)");
    command->get_option("--bunny")->check(CLI::ExistingFile);
    resolveShippedData(command, {{"--bunny", &o->bunnyPath, "Stanford bunny PLY"}});
    command->add_option("--sparse", o->sparse, "Sparse points per model to sweep (comma-separated)")
        ->check(integerList(1, 1 << 20));
    command
        ->add_option("--strides", o->strides,
                     "VAL strides on the 640x480 depth frame to sweep (1 = 640x480 VALs, 8 = 80x60)")
        ->check(integerList(1, 64));
    command->add_option("--kcache", o->kCache, "K_cache values to sweep")->check(integerList(16, 4096));
    command->add_option("--channels", o->channels, "Channels to sweep: diffuse,glossy,occlusion");
    command->add_option("--resolutions", o->resolutions, "Output resolutions to sweep, WxH")->check(sizeList(8192));
    command->add_option("--meshes", o->meshes, "Sphere triangle counts to sweep (the bunny adds ~15k)")
        ->check(integerList(1, 100'000'000));
    command->add_option("--adaptive", o->adaptive, "Adaptive mode values to sweep: off,on");
    command->add_option(
        "--volumes", o->volumes,
        "Imperfect-volumes rows, resolution:points-per-triangle:rays-per-voxel:bounces (comma-separated)");
    command->add_option("--prt", o->prt,
                        "Multi-scale PRT rows, entry-points:walks-per-entry:clusters:basis-vectors[:gather-points] "
                        "(comma-separated; gather points default 1024, 0 = the first bounce at every vertex)");
    command->add_option("--cache-dir", o->prtCacheDir,
                        "Multi-scale PRT's precompute cache folder (default none: every PRT row precomputes)");
    command
        ->add_option("--trees", o->trees,
                     "Comma-separated valTreeThreshold values (gather with a cut; axis \"tree\"; \"\" = none)")
        ->check(numberList(0.0, 1e6, true));
    command->add_option("--backends", o->backends,
                        "LightSkin backends to sweep: gl,cpu (the CPU backend, gi.backend \"cpu\")");
    command->add_option("--default-sparse", o->defaults.sparse, "Default configuration: sparse points per model")
        ->check(CLI::Range(1, 1 << 20));
    command->add_option("--default-stride", o->defaults.stride, "Default configuration: VAL stride")
        ->check(CLI::Range(1, 64));
    command->add_option("--default-kcache", o->defaults.kCache, "Default configuration: K_cache")
        ->check(CLI::Range(16, 4096));
    command
        ->add_option("--default-channels", o->defaults.channels,
                     "Default configuration: 1 diffuse, 2 +glossy, 3 +occlusion")
        ->check(CLI::Range(1, 3));
    command->add_option("--default-width", o->defaults.width, "Default configuration: output width")
        ->check(CLI::Range(16, 8192));
    command->add_option("--default-height", o->defaults.height, "Default configuration: output height")
        ->check(CLI::Range(16, 8192));
    command->add_option("--default-mesh", o->defaults.sphereTriangles, "Default configuration: sphere triangles")
        ->check(CLI::Range(1, 100'000'000));
    command->add_option("--frames", o->frames, "Timed frames per configuration (median; after one warm-up)")
        ->check(CLI::Range(1, 100));
    command->add_option("--truth-stride", o->truthStride, "VAL stride of the ground truth")->check(CLI::Range(1, 64));
    command->add_option("--truth-grid", o->truthGrid, "Ground-truth receivers per image row")
        ->check(CLI::Range(4, 1024));
    command
        ->add_option("--max-brute", o->maxBruteInteractions,
                     "Skip brute force above this many VAL x pixel interactions")
        ->check(finiteIn(0.0, 1e18));
    command->add_option("--max-truth", o->maxTruthRays, "Skip the ground truth above this many rays")
        ->check(finiteIn(0.0, 1e18));
    command->add_option("--temporal-frames", o->temporalFrames, "Frames per temporal sequence")
        ->check(CLI::Range(2, 1000));
    command
        ->add_option("--temporal-tolerance", o->temporalTolerance,
                     "Metres: a tracked vertex counts as seen when the G-buffer position at its pixel is this close")
        ->check(finiteIn(0.0, 10.0));
    command->add_option("--temporal-sparse", o->temporalSparse, "Sparse points per model in the temporal sequences")
        ->check(integerList(1, 1 << 20));
    command->add_flag(
        "--no-temporal", [o](std::int64_t) { o->temporal = false; }, "Skip the temporal sequences");
    command->add_option(
        "--export-blender", o->exportBlender,
        "Only write the default view (diffuse + glossy) for scripts/blender_reference.sh into this folder");
    command->add_flag("--check", o->check, "Fail (exit 3) unless error falls as sparse points and VALs grow");
    command->add_option("--tolerance", o->tolerance, "Noise allowed in the monotonicity check (relative)")
        ->check(finiteIn(0.0, 10.0));
    command->add_flag(
        "--table1", o->table1,
        "Instead of the sweep: the paper's Table 1 setups (1920x1080; 4k, 16k sparse points; 16k, 64k, 512k VALs), "
        "stage times and speed-up over the brute force (extrapolated from a pixel subset, checked on the first map)");
    command->add_flag(
        "--kinect", o->kinect,
        "Instead of the sweep: the Kinect setups (640x480 output; VAL maps 160x120, 320x240, 640x480; 1k, 4k sparse)");
    command->add_option("--table-output", o->tableOutput, "--table1/--kinect: output WxH")->check(sizeList(8192));
    command
        ->add_option("--table-sparse", o->tableSparse,
                     "--table1/--kinect: sparse points over both models (comma-separated)")
        ->check(integerList(1, 1 << 20));
    command->add_option("--table-vals", o->tableVals, "--table1/--kinect: VAL maps WxH (comma-separated)")
        ->check(sizeList(8192));
    command
        ->add_option("--table-subset", o->tableSubset,
                     "--table1/--kinect: brute force on every n-th pixel per direction")
        ->check(CLI::Range(1, 64));
    command->add_option("--table-frames", o->tableFrames, "--table1/--kinect: timed frames per cell (median)")
        ->check(CLI::Range(1, 100));
    command
        ->add_option("--from-json", o->fromJson,
                     "Do not measure: read this bench.json and rewrite the outputs (--out) and --docs from it")
        ->check(CLI::ExistingFile);
    command->callback([o, &exitCode] {
        // Every output is checked before the measurements (minutes) start.
        checkOutputFile(std::filesystem::path(o->out) / "bench.json", {o->bunnyPath, o->fromJson}, "--out");
        if (!o->docs.empty()) checkOutputFile(o->docs, {o->bunnyPath, o->fromJson}, "--docs");
        if (!o->exportBlender.empty())
            checkOutputFile(std::filesystem::path(o->exportBlender) / "scene.json", {o->bunnyPath}, "--export-blender");
        const StopSignals stopSignals; // Ctrl-C and SIGTERM: finish the measurement, output what was measured
        o->stopRequested = [] { return StopSignals::requested(); };
        const int code = bench::runSweepCommand(*o);
        exitCode = StopSignals::requested() ? StopSignals::exitCode() : code;
    });
}

} // namespace

static const CommandRegistration registration{"bench", &addBenchCommand};

} // namespace lightskin::apps
