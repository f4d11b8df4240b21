// `lightskin bench-cpu`: argument parsing only; the benchmark is lightskin::bench (CpuBench.h).
#include "CliSupport.h"
#include "Commands.h"
#include "ToolCommands.h"

#include <lightskin/bench/CpuBench.h>
#include <lightskin/bench/OptionLists.h>
#include <lightskin/core/Error.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace lightskin::apps {

namespace {

void addBenchCpuCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand("bench-cpu", toolDescription("bench-cpu"));
    auto options = std::make_shared<bench::CpuBenchOptions>();
    auto sparse = std::make_shared<std::string>("1024");
    auto maps = std::make_shared<std::string>("160x120");
    auto threads = std::make_shared<std::string>("1,2");
    auto targets = std::make_shared<std::string>("");
    auto trees = std::make_shared<std::string>("0");
    command->add_option("--width", options->outputWidth, "Output width (pixels)")->check(CLI::Range(16, 8192));
    command->add_option("--height", options->outputHeight, "Output height (pixels)")->check(CLI::Range(16, 8192));
    command->add_option("--sparse", *sparse, "Comma-separated sparse point counts (total of both meshes)")
        ->check(integerList(1, 1 << 20));
    command
        ->add_option("--vals", *maps,
                     "Comma-separated VAL map sizes WxH (160x120: a 640x480 depth map at VAL stride 4)")
        ->check(sizeList(8192));
    command->add_option("--threads", *threads, "Comma-separated CPU thread counts")->check(integerList(1, 1024));
    command->add_option("--simd", *targets,
                        "Comma-separated SIMD targets to compare (e.g. AVX3,AVX2,SSE4; default: the dispatched one)");
    command
        ->add_option("--tree", *trees,
                     "Comma-separated LightSkinSettings::valTreeThreshold values of the CPU rows (0 = flat gather, "
                     "first if given: the cut's error is against it)")
        ->check(numberList(0.0, 100.0));
    command->add_option("--repeat", options->repeat, "Timed frames per configuration (the minimum is reported)")
        ->check(CLI::Range(1, 1000));
    command
        ->add_option("--peak", options->peakGflops,
                     "The machine's FMA peak in GFLOP/s (build/bench/lightskin_bench_peak) for the % column")
        ->check(finiteIn(0.0, 1e9));
    command->add_option("--out", options->out,
                        "Also write bench-cpu.json and its scaling plot (time against VAL count) into this folder");
    command->add_flag(
        "--no-gl", [options](std::int64_t) { options->gl = false; }, "Skip the GL path");
    command->callback([=, &exitCode] {
        if (!options->out.empty()) checkOutputFile(std::filesystem::path(options->out) / "bench-cpu.json", {}, "--out");
        options->sparse = bench::splitList<int>(*sparse, [](const std::string& s) { return std::stoi(s); });
        options->valMaps = bench::splitList<std::string>(*maps, [](const std::string& s) { return s; });
        options->threads = bench::splitList<int>(*threads, [](const std::string& s) { return std::stoi(s); });
        options->targets = bench::splitList<std::string>(*targets, [](const std::string& s) { return s; });
        options->treeThresholds = bench::splitList<float>(*trees, [](const std::string& s) { return std::stof(s); });
        const StopSignals stopSignals; // Ctrl-C and SIGTERM: finish the measurement, output what was measured
        options->stopRequested = [] { return StopSignals::requested(); };
        bench::runCpuBench(*options);
        exitCode = StopSignals::exitCode();
    });
}

} // namespace

static const CommandRegistration registration{"bench-cpu", &addBenchCpuCommand};

} // namespace lightskin::apps
