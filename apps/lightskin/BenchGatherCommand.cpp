// `lightskin bench-gather`: argument parsing only; the benchmark is lightskin::bench (GatherBench.h).
#include "CliSupport.h"
#include "Commands.h"
#include "ToolCommands.h"

#include <lightskin/bench/GatherBench.h>
#include <lightskin/bench/OptionLists.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace lightskin::apps {

namespace {

void addBenchGatherCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand("bench-gather", toolDescription("bench-gather"));
    auto options = std::make_shared<bench::GatherBenchOptions>();
    auto sparse = std::make_shared<std::string>("1024");
    auto maps = std::make_shared<std::string>("160x120");
    auto kCache = std::make_shared<std::string>("128");
    auto tree = std::make_shared<std::string>("0");
    command->add_option("--width", options->outputWidth, "Output width (pixels)")->check(CLI::Range(16, 8192));
    command->add_option("--height", options->outputHeight, "Output height (pixels)")->check(CLI::Range(16, 8192));
    command->add_option("--sparse", *sparse, "Comma-separated sparse point counts (total of both meshes)")
        ->check(integerList(1, 1 << 20));
    command->add_option("--vals", *maps, "Comma-separated VAL map sizes WxH, e.g. 160x120,320x240")
        ->check(sizeList(8192));
    command->add_option("--kcache", *kCache, "Comma-separated K_cache values (multiples of 16)")
        ->check(integerList(16, 4096));
    command->add_option("--repeat", options->repeat, "Frames per configuration (the minimum is reported)")
        ->check(CLI::Range(1, 1000));
    command->add_flag(
        "--no-brute", [options](std::int64_t) { options->brute = false; }, "Skip the brute force");
    command->add_option("--out", options->out,
                        "Also write bench-gather.json and its scaling plot (time against VAL count) into this folder");
    command->add_flag("--compute", options->compute,
                      "Gather with the compute-shader variant instead of fragment passes");
    command->add_option("--tree", *tree, "Comma-separated LightSkinSettings::valTreeThreshold values (0 = flat gather)")
        ->check(numberList(0.0, 1e6));
    command->add_flag("--tree-bvh", options->treeBvh,
                      "With --tree > 0: also the BVH beside the VAL map's quadtree, side by side");
    command
        ->add_option("--brute-subset", options->bruteSubset,
                     "Brute force on this many random covered pixels only, its time scaled to all (0 = all)")
        ->check(CLI::Range(0, 1 << 24));
    command->add_flag("--near-field", options->nearField,
                      "Guard G12 on: near-field VALs as areas (off by default), to time it against the default");
    command->add_flag("--diffuse-only", options->diffuseOnly,
                      "Only the diffuse setup (the one compared with the brute force)");
    command->callback([=, &exitCode] {
        if (!options->out.empty())
            checkOutputFile(std::filesystem::path(options->out) / "bench-gather.json", {}, "--out");
        options->treeThresholds = bench::splitList<float>(*tree, [](const std::string& s) { return std::stof(s); });
        options->sparse = bench::splitList<int>(*sparse, [](const std::string& s) { return std::stoi(s); });
        options->kCache = bench::splitList<int>(*kCache, [](const std::string& s) { return std::stoi(s); });
        options->valMaps = bench::splitList<std::string>(*maps, [](const std::string& s) { return s; });
        const StopSignals stopSignals; // Ctrl-C and SIGTERM: finish the measurement, output what was measured
        options->stopRequested = [] { return StopSignals::requested(); };
        bench::runGatherBench(*options);
        exitCode = StopSignals::exitCode();
    });
}

} // namespace

static const CommandRegistration registration{"bench-gather", &addBenchGatherCommand};

} // namespace lightskin::apps
