// `lightskin bench-realdepth`: argument parsing only; the benchmark is lightskin::bench (RealDepthBench.h).
#include "CliSupport.h"
#include "Commands.h"
#include "ToolCommands.h"

#include <lightskin/bench/RealDepthBench.h>

#include <filesystem>
#include <memory>
#include <string>

namespace lightskin::apps {

namespace {

void addBenchRealDepthCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand("bench-realdepth", toolDescription("bench-realdepth"));
    auto options = std::make_shared<bench::RealDepthBenchOptions>();
    command->add_option("--data", options->data,
                        "Folder of the bundled recordings (relative paths of the default: beside the program or the "
                        "build, never the current folder)");
    command->add_option(
        "--scene", options->scene,
        "Template scene (relative paths of the default: beside the program or the build, never the current folder)");
    resolveShippedData(
        command, {{"--data", &options->data, "bundled recordings"}, {"--scene", &options->scene, "template scene"}});
    command->add_option("--out", options->out, "Output folder (tables, PNGs of the first frame's indirect light)");
    command->add_option(
        "--models", options->models,
        "Comma-separated light models: old, robust, robust-nocap (robust without the vertex irradiance cap G10), "
        "robust-noburied (robust without the buried sparse-point rule G11), "
        "robust-area (robust with the near-field VALs as areas G12, off by default)");
    command->add_option("--sink", options->sinks, "Depths the objects are sunk into the surface, metres")
        ->check(finiteIn(-1.0, 1.0));
    command
        ->add_option("--max-frames", options->maxFrames,
                     "Cap on the frames per recording (each has its own count: ICL-NUIM 5, the .oni all)")
        ->check(CLI::Range(1, 1000000));
    command->add_option("--recordings", options->recordings,
                        "Comma-separated recordings (tum-fr2-desk, icl-nuim, pcl-kinect-tiff, tum-fr3-office, "
                        "oni-kinect-v1; default all)");
    command->add_flag(
        "--maps", options->maps,
        "Also write per frame the speckle maps and the luminance of both indirect images (raw float32), "
        "a CSV of the speckle pixels and one of the tracked points that flicker most, and for each case's "
        "first frame the depth VALs (CSV) and the G-buffer's world positions and normals (raw float32; "
        "bench/plots/realdepth_val_analysis.py reads them)");
    command
        ->add_option("--truth", options->truthReceivers,
                     "At this many bunny pixels of each case's first frame, the Embree truth with visibility "
                     "(4 x 8 cells per VAL) into images/<case>_truth.csv with the G-buffer position and normal")
        ->check(CLI::Range(0, 1 << 24));
    command->add_option("--truth-pixels", options->truthPixels,
                        "Pixels \"u,v;u,v\" added to --truth's (16 x 32 cells per VAL)");
    command->callback([options, &exitCode] {
        checkOutputFile(std::filesystem::path(options->out) / "report.md", {options->data, options->scene}, "--out");
        const StopSignals stopSignals; // Ctrl-C and SIGTERM: finish the measurement, output what was measured
        options->stopRequested = [] { return StopSignals::requested(); };
        bench::runRealDepthBench(*options);
        exitCode = StopSignals::exitCode();
    });
}

} // namespace

static const CommandRegistration registration{"bench-realdepth", &addBenchRealDepthCommand};

} // namespace lightskin::apps
