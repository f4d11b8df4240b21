// `lightskin bench-cull`: argument parsing only; the benchmark is lightskin::bench (CullBench.h).
#include "Commands.h"
#include "ToolCommands.h"

#include <lightskin/bench/CullBench.h>
#include <lightskin/bench/OptionLists.h>
#include <lightskin/core/Error.h>

#include <memory>
#include <string>
#include <vector>

namespace lightskin::apps {

namespace {

void addBenchCullCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand("bench-cull", toolDescription("bench-cull"));
    auto options = std::make_shared<bench::CullBenchOptions>();
    auto counts = std::make_shared<std::string>("16384,65536,524288");
    command->add_option("--vals", *counts, "Comma-separated VAL counts");
    command->add_option("--repeat", options->repeat, "Frames per variant (the minimum upload stage time is reported)");
    command->callback([=, &exitCode] {
        options->counts = bench::splitList<std::uint32_t>(*counts, [](const std::string& s) {
            const unsigned long n = std::stoul(s);
            if (n > 16u * 1024u * 1024u) throw Error("--vals", std::nullopt, "at most 16M VALs, got " + s);
            return std::uint32_t(n);
        });
        if (options->repeat < 1) throw Error("--repeat", std::nullopt, "must be at least 1");
        bench::runCullBench(*options);
        exitCode = 0;
    });
}

} // namespace

static const CommandRegistration registration{"bench-cull", &addBenchCullCommand};

} // namespace lightskin::apps
