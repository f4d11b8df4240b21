#pragma once
// `lightskin bench-cull` (apps/lightskin): see bench/src/CullBench.cpp and docs/BENCHMARKS.md.

#include <lightskin/bench/StopRequest.h>

#include <cstdint>
#include <string>
#include <vector>

namespace lightskin::bench {

struct CullBenchOptions {
    std::vector<std::uint32_t> counts;
    int repeat = 5;
    /// Asked between measurements (Ctrl-C in the command): true = stop, output what was measured, marked interrupted.
    StopRequested stopRequested;
};

/// The adaptive VAL cull: stable compaction against atomic append (upload stage times).
/// Needs no current GL context (creates its own headless one); throws lightskin::Error on bad input.
void runCullBench(const CullBenchOptions& options);

} // namespace lightskin::bench
