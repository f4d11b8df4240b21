#pragma once
// `lightskin bench-cull` (apps/lightskin): see bench/src/CullBench.cpp and docs/BENCHMARKS.md.

#include <cstdint>
#include <string>
#include <vector>

namespace lightskin::bench {

struct CullBenchOptions {
    std::vector<std::uint32_t> counts;
    int repeat = 5;
};

/// The adaptive VAL cull: stable compaction against atomic append (upload stage times).
/// Needs no current GL context (creates its own headless one); throws lightskin::Error on bad input.
void runCullBench(const CullBenchOptions& options);

} // namespace lightskin::bench
