// `lightskin bench-cpu`: argument parsing only; the benchmark is lightskin::bench (CpuBench.h).
#include "Commands.h"
#include "ToolCommands.h"

#include <lightskin/bench/CpuBench.h>
#include <lightskin/bench/OptionLists.h>
#include <lightskin/core/Error.h>

#include <cstdint>
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
    command->add_option("--width", options->outputWidth, "Output width (pixels)");
    command->add_option("--height", options->outputHeight, "Output height (pixels)");
    command->add_option("--sparse", *sparse, "Comma-separated sparse point counts (total of both meshes)");
    command->add_option("--vals", *maps,
                        "Comma-separated VAL map sizes WxH (160x120: a 640x480 depth map at VAL stride 4)");
    command->add_option("--threads", *threads, "Comma-separated CPU thread counts");
    command->add_option("--simd", *targets,
                        "Comma-separated SIMD targets to compare (e.g. AVX3,AVX2,SSE4; default: the dispatched one)");
    command->add_option("--repeat", options->repeat, "Timed frames per configuration (the minimum is reported)")
        ->check(CLI::Range(1, 1000));
    command->add_option("--peak", options->peakGflops,
                        "The machine's FMA peak in GFLOP/s (build/bench/lightskin_bench_peak) for the % column");
    command->add_option("--out", options->out,
                        "Also write bench-cpu.json and its scaling plot (time against VAL count) into this folder");
    command->add_flag(
        "--no-gl", [options](std::int64_t) { options->gl = false; }, "Skip the GL path");
    command->callback([=, &exitCode] {
        options->sparse = bench::splitList<int>(*sparse, [](const std::string& s) { return std::stoi(s); });
        options->valMaps = bench::splitList<std::string>(*maps, [](const std::string& s) { return s; });
        options->threads = bench::splitList<int>(*threads, [](const std::string& s) {
            const int n = std::stoi(s);
            if (n < 1) throw Error("--threads", std::nullopt, "thread counts must be >= 1, got " + s);
            return n;
        });
        options->targets = bench::splitList<std::string>(*targets, [](const std::string& s) { return s; });
        bench::runCpuBench(*options);
        exitCode = 0;
    });
}

} // namespace

static const CommandRegistration registration{"bench-cpu", &addBenchCpuCommand};

} // namespace lightskin::apps
