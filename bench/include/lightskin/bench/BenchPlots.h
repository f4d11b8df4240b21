#pragma once
// The plots of the bench commands, drawn by matplotlib from their JSON (BenchReport.h):
// bench/plots/bench_plots.py (Pareto plot of error against time, VAL-count scaling, flicker). Why a
// script and not drawing code, and how to read the plots: docs/BENCHMARKS.md, "Plots".
#include <string>

namespace lightskin::bench {

struct PlotOutcome {
    bool drawn = false;  ///< false: skipped (no python3 or no matplotlib); the JSON is unaffected
    std::string message; ///< what was written, or why the plots were skipped and how to get them
};

/// Runs the plot script on `jsonFile`, writing P.png, P-vs-brute.png, P-scaling.png, P-flicker.png
/// (those the JSON has rows for) and P-plots.json into `outDir`, P = `prefix`, the JSON's "bench" key
/// (Report::bench). Stale plots of an earlier run are removed first, so a skipped run leaves none behind. The
/// interpreter: $LIGHTSKIN_PYTHON, else /usr/bin/python3 (Debian's, where python3-matplotlib installs), else python3 on
/// PATH; the script: $LIGHTSKIN_BENCH_PLOTS, else the source tree's. Returns drawn = false when the interpreter or
/// matplotlib is missing; throws lightskin::Error naming the file when the script fails for another reason (bad JSON,
/// unwritable folder).
PlotOutcome drawPlots(const std::string& jsonFile, const std::string& outDir, const std::string& prefix = "bench");

/// Removes the files drawPlots writes into `outDir` (those of an earlier run), drawing nothing.
void removePlots(const std::string& outDir, const std::string& prefix = "bench");

} // namespace lightskin::bench
