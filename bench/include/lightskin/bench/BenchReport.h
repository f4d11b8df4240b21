#pragma once
// Results of `lightskin bench` (SweepBench.h) and their outputs: CSV, JSON (the source of the plots,
// BenchPlots.h) and the Markdown section regenerated into docs/BENCHMARKS.md between markers. The
// table benches (bench-gather, bench-cpu, bench-realdepth) write the same JSON (Report with their
// rows in runs/temporal); its keys: docs/bench/SCHEMA.md.
#include <lightskin/gi/common/Technique.h>
#include <lightskin/eval/ImageMetrics.h>
#include <lightskin/gi/volumes/ImperfectVolumes.h>
#include <lightskin/gi/prt/MultiscalePrt.h>

#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace lightskin::bench {

/// One configuration of the sweep: the knob values. `axis`/`value` name the knob this row varies
/// (one-at-a-time around the default configuration).
struct Config {
    std::string axis = "default";
    std::string value = "-";
    int sparse = 1024; ///< sparse points per model
    int stride = 4;    ///< VAL stride on the 640x480 depth frame (4: 160x120 VAL map)
    int kCache = 128;
    int channels = 3; ///< 1 diffuse, 2 + glossy, 3 + occlusion
    int width = 640, height = 480;
    std::size_t sphereTriangles = 20000;
    bool adaptive = false;
    /// LightSkinSettings::valTreeThreshold (axis "tree"); 0 = the flat gather.
    float valTree = 0.0f;
    gi::Backend backend = gi::Backend::Gl; ///< LightSkin on gl or on the cpu backend (gi::CpuLightSkin)
    bool isDefault = false;
    /// LightSkin, or imperfect volumes (its knobs in `volumes`, axis "volumes": value resolution:points per
    /// triangle:rays per voxel:bounces; diffuse only, so channels = 1).
    gi::Technique technique = gi::Technique::LightSkin;
    gi::ImperfectVolumesSettings volumes;
    /// Multi-scale PRT: its knobs, axis "prt": value entries:walks:clusters:D; diffuse only.
    gi::MultiscalePrtSettings prt;
};

const char* channelName(int channels);

struct RunResult {
    Config config;
    /// The technique and the backend that produced this row ("LightSkin"/"brute force", "gl"/"cpu"): the
    /// plots draw one series per pair, so a new technique or backend needs no plotting code.
    std::string method = "LightSkin";
    std::string backend = "gl";
    /// Rows of one method and backend that differ in other knobs than the VAL count (bench-gather's
    /// "sparse 1024, +occlusion"): one line each in the scaling plot. "" for the sweep's rows.
    std::string series;
    std::size_t vals = 0;      ///< VALs the generator produced
    std::size_t covered = 0;   ///< output pixels covered by virtual content
    std::size_t triangles = 0; ///< of both virtual meshes
    double gpuMs = 0.0;        ///< median over frames of the sum of the technique's GPU stages
    double cpuMs = 0.0;        ///< median wall time of render() + glFinish
    double valsMs = 0.0;       ///< median GPU time of the VAL generation (common to all techniques)
    double prepareMs = 0.0;    ///< wall time of create() + prepare() (sparse points: load time, not per frame)
    std::vector<std::pair<std::string, double>> stages; ///< medians, execution order
    std::optional<double> bruteMs;                      ///< brute force GPU time on the same inputs (one frame)
    std::optional<eval::ImageError> vsBrute;            ///< against the brute force, same VALs, full image
    std::optional<eval::ImageError> vsTruth;            ///< against the ray-traced ground truth (receiver grid)
    /// Against the brute force on the finest (truth-stride) VAL map of the same frame: what the VAL
    /// stride and the approximation cost together, with the same reflectance model.
    std::optional<eval::ImageError> vsFineBrute;
    /// The brute force on this run's VAL map against the one on the finest map: what the VAL stride alone
    /// costs, no approximation in it (the "falls as VALs grow" check reads this).
    std::optional<eval::ImageError> bruteVsFineBrute;
    std::size_t truthReceivers = 0;
    bool isBrute = false; ///< the brute-force row itself (its error against the truth)
};

struct TemporalResult {
    std::string sequence;  ///< camera | light | edges
    std::string technique; ///< "lightskin sparse N" or "brute force"
    int frames = 0;
    std::size_t pointPairs = 0;       ///< (point, frame pair) samples
    double flicker = 0.0;             ///< RMS frame-to-frame change / mean reference level
    double referenceFlicker = 0.0;    ///< the same for the reference (brute force)
    double excessFlicker = 0.0;       ///< RMS of (our change - reference change) / mean reference level
    std::string method = "LightSkin"; ///< technique family, as RunResult::method
    std::string backend = "gl";
};

struct CheckResult {
    std::string name;
    bool passed = false;
    bool required = true; ///< false: reported only (does not fail the run)
    std::string detail;
};

struct Report {
    std::string bench = "bench"; ///< the command: bench, bench-gather, bench-cpu, bench-realdepth (names the plots)
    std::string machine, renderer, date, command, loadStart, loadEnd;
    int truthStride = 0;
    int frames = 0;
    double seconds = 0.0;
    bool quick = false;
    /// Stopped early (StopRequest.h): the rows are those measured before the stop. JSON "status": "interrupted"
    /// (else "complete"); the Markdown says so in its title.
    bool interrupted = false;
    std::vector<RunResult> runs;
    std::vector<TemporalResult> temporal;
    std::vector<CheckResult> checks;
};

/// The run's identity for a Report: the command line (program name without its folder), the UTC
/// date, the CPU model with its thread count, the load average (1/5/15 min) now.
std::string commandLine();
std::string utcNow();
std::string machineDescription();
std::string loadAverage();
/// A Report stamped with the run's identity (above) and the load at its start, for the bench `bench`.
Report startReport(std::string bench, int frames);

/// Writes `report` as JSON (docs/bench/SCHEMA.md); throws lightskin::Error naming the file when it cannot.
void writeJson(const Report& report, const std::string& file);
/// Reads a bench JSON back (to redraw the plot or regenerate the docs without re-running).
/// Throws lightskin::Error on a missing or malformed file.
Report readReport(const std::string& jsonFile);
/// Writes bench.csv, bench.json and bench.md into `dir` (created if missing), then the plots from the
/// JSON (drawPlots, BenchPlots.h: skipped with a warning naming the fix when python3-matplotlib is missing).
void writeOutputs(const Report& report, const std::string& dir);
/// Writes `dir`/<report.bench>.json (created if missing), then its plots (drawPlots, as writeOutputs; not for an
/// interrupted run, which should end at once: the log says how to draw them): the output of the table benches.
void writeJsonAndPlots(const Report& report, const std::string& dir);
/// The Markdown section (between the markers).
std::string markdown(const Report& report);
/// Replaces the text between `<!-- lightskin-bench:begin -->` and `<!-- lightskin-bench:end -->` in
/// `docsFile` (appends a section with the markers when they are missing).
void regenerateDocs(const Report& report, const std::string& docsFile);

} // namespace lightskin::bench
