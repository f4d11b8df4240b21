// The bench JSON (BenchReport.h, docs/bench/SCHEMA.md) and the plots drawn from it with three GI
// techniques. The reports are built here, so every expectation is known without running a benchmark:
//  * round trip: a table bench's report (bench-gather rows with series and stages, set and unset optional
//    errors, temporal rows, checks) reads back field for field; a missing key is an error naming the file;
//  * three techniques: LightSkin (GL and CPU), imperfect volumes and multi-scale PRT (each under a spelling
//    of its method key that the benches write or may write) plus the brute force get one series each,
//    each technique keeps one colour through the Pareto, scaling and flicker plots, the colours differ,
//    every series' colour is found in the images and no label overlaps another;
//  * a stopped run: "status": "interrupted", read back, no plots.
#include "ExpectError.h"
#include "TestPaths.h"

#include <lightskin/bench/BenchPlots.h>
#include <lightskin/bench/BenchReport.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace {

using lightskin::bench::Report;
using lightskin::bench::RunResult;
using lightskin::bench::TemporalResult;
using lightskin::test::scratchDir;

lightskin::eval::ImageError error(double relativeMse, double ssim) {
    lightskin::eval::ImageError e;
    e.relativeMse = relativeMse;
    e.ssim = ssim;
    e.meanAbsoluteError = relativeMse / 3.0;
    e.maxAbsoluteError = relativeMse * 7.0;
    e.psnr = 30.0 + relativeMse;
    e.pixelsCompared = 1234;
    return e;
}

nlohmann::json readJson(const std::filesystem::path& path) {
    std::ifstream in(path);
    return nlohmann::json::parse(in);
}

/// A sweep-like report with three techniques. Each technique has three VAL strides (8, 4, 2: 4800, 19200,
/// 76800 VALs) at times that grow with the VAL count and errors that fall, spread in time so that the
/// points (and their labels) do not sit on each other; the default row is LightSkin GL at stride 4.
Report threeTechniques() {
    Report report;
    report.machine = "test machine";
    report.renderer = "test renderer";
    report.date = "2026-11-30 00:00 UTC";
    report.command = "lightskin bench (synthetic, BenchJsonTest)";
    report.truthStride = 2;
    report.frames = 3;
    struct Technique {
        std::string method, backend;
        double msPerKiloVal; ///< time per frame per 1000 VALs
        double error;        ///< relative MSE at stride 8
    };
    const std::vector<Technique> techniques = {{"LightSkin", "gl", 2.0, 2e-2},
                                               {"LightSkin", "cpu", 6.0, 2.1e-2},
                                               {"imperfect volumes", "gl", 0.5, 5e-2},
                                               {"multiscale-prt", "gl", 0.15, 9e-2}};
    for (const Technique& t : techniques)
        for (int stride : {8, 4, 2}) {
            RunResult r;
            r.method = t.method;
            r.backend = t.backend;
            r.config.backend = *lightskin::gi::parseBackend(t.backend);
            r.config.axis = stride == 4 ? "default" : "stride";
            r.config.value = std::to_string(stride);
            r.config.stride = stride;
            r.config.isDefault = stride == 4;
            r.vals = std::size_t(640 / stride) * std::size_t(480 / stride);
            r.gpuMs = t.msPerKiloVal * double(r.vals) / 1000.0;
            r.vsTruth = error(t.error * 8.0 / (8.0 + 8.0 / stride), 0.9);
            r.vsBrute = error(t.error * 0.5 * 8.0 / (8.0 + 8.0 / stride), 0.95);
            if (t.method == "LightSkin" && t.backend == "gl") r.bruteMs = 0.2 * double(r.vals); // brute force
            report.runs.push_back(r);
        }
    RunResult brute;
    brute.method = "brute force";
    brute.isBrute = true;
    brute.config.axis = "brute";
    brute.config.value = "-";
    brute.vals = 19200;
    brute.bruteMs = 3840.0;
    brute.vsTruth = error(1e-2, 0.99);
    report.runs.push_back(brute);
    for (const char* sequence : {"camera", "light", "edges"}) {
        report.temporal.push_back({sequence, "brute force (reference)", 8, 4000, 0.10, 0.10, 0.0, "brute force", "gl"});
        report.temporal.push_back({sequence, "lightskin, 1024 sparse", 8, 4000, 0.11, 0.10, 0.02, "LightSkin", "gl"});
        report.temporal.push_back(
            {sequence, "imperfect volumes, 64^3", 8, 4000, 0.12, 0.10, 0.03, "imperfect volumes", "gl"});
        report.temporal.push_back(
            {sequence, "multi-scale PRT, D 8", 8, 4000, 0.13, 0.10, 0.04, "multi-scale PRT", "gl"});
    }
    return report;
}

std::string colourOf(const nlohmann::json& series, const std::string& method, const std::string& backend) {
    for (const auto& s : series)
        if (s.at("method") == method && s.at("backend") == backend) return s.at("colour");
    return "";
}

/// Pixels of exactly this colour (within 2 of 255 per channel: antialiasing leaves the interior exact).
int pixelsOf(const cv::Mat& image, const std::string& hex) {
    const int r = std::stoi(hex.substr(1, 2), nullptr, 16), g = std::stoi(hex.substr(3, 2), nullptr, 16),
              b = std::stoi(hex.substr(5, 2), nullptr, 16);
    int count = 0;
    for (int y = 0; y < image.rows; ++y)
        for (int x = 0; x < image.cols; ++x) {
            const cv::Vec3b p = image.at<cv::Vec3b>(y, x); // BGR
            if (std::abs(p[2] - r) <= 2 && std::abs(p[1] - g) <= 2 && std::abs(p[0] - b) <= 2) ++count;
        }
    return count;
}

} // namespace

TEST(BenchJson, ATableReportReadsBackFieldForField) {
    Report report;
    report.bench = "bench-gather";
    report.machine = "cpu, 2 threads";
    report.renderer = "llvmpipe";
    report.date = "2026-11-30 17:00 UTC";
    report.command = "lightskin bench-gather --vals 40x30";
    report.loadStart = "1.00 2.00 3.00";
    report.loadEnd = "4.00 5.00 6.00";
    report.frames = 3;
    report.seconds = 12.5;
    RunResult run;
    run.method = "LightSkin";
    run.backend = "cpu";
    run.series = "sparse 256, K_cache 128, +occlusion";
    run.config.axis = "vals";
    run.config.value = "40x30";
    run.config.sparse = 256;
    run.config.kCache = 128;
    run.config.channels = 3;
    run.config.width = 160;
    run.config.height = 120;
    run.vals = 1200;
    run.covered = 9000;
    run.triangles = 20000;
    run.gpuMs = 12.25;
    run.cpuMs = 20.5;
    run.stages = {{"upload", 0.5}, {"gather", 9.75}};
    run.bruteMs = 80.0;
    run.vsBrute = error(1e-3, 0.97);
    RunResult brute;
    brute.method = "brute force";
    brute.isBrute = true;
    brute.config.channels = 1;
    brute.vals = 1200;
    brute.bruteMs = 80.0;
    report.runs = {run, brute};
    report.temporal.push_back(
        {"icl-nuim, sink 0 mm", "LightSkin (robust light model)", 5, 777, 0.2, 0.1, 0.05, "LightSkin", "gl"});
    report.checks.push_back({"error falls", false, false, "reported only"});

    const auto dir = scratchDir("bench_json_roundtrip");
    lightskin::bench::writeJson(report, (dir / "bench-gather.json").string());
    const Report back = lightskin::bench::readReport((dir / "bench-gather.json").string());

    EXPECT_EQ(back.bench, report.bench);
    EXPECT_EQ(back.machine, report.machine);
    EXPECT_EQ(back.command, report.command);
    EXPECT_EQ(back.loadEnd, report.loadEnd);
    EXPECT_EQ(back.frames, report.frames);
    EXPECT_EQ(back.seconds, report.seconds);
    ASSERT_EQ(back.runs.size(), 2u);
    const RunResult& r = back.runs[0];
    EXPECT_EQ(r.method, run.method);
    EXPECT_EQ(r.backend, run.backend);
    EXPECT_EQ(r.config.backend, lightskin::gi::Backend::Cpu); // the config's backend follows the row's
    EXPECT_EQ(r.series, run.series);
    EXPECT_EQ(r.config.axis, run.config.axis);
    EXPECT_EQ(r.config.value, run.config.value);
    EXPECT_EQ(r.config.sparse, run.config.sparse);
    EXPECT_EQ(r.config.kCache, run.config.kCache);
    EXPECT_EQ(r.config.channels, run.config.channels);
    EXPECT_EQ(r.config.width, run.config.width);
    EXPECT_EQ(r.vals, run.vals);
    EXPECT_EQ(r.covered, run.covered);
    EXPECT_EQ(r.triangles, run.triangles);
    EXPECT_EQ(r.gpuMs, run.gpuMs);
    EXPECT_EQ(r.cpuMs, run.cpuMs);
    std::map<std::string, double> stages(r.stages.begin(), r.stages.end()),
        expectedStages(run.stages.begin(), run.stages.end());
    EXPECT_EQ(stages, expectedStages);
    EXPECT_EQ(r.bruteMs, run.bruteMs);
    ASSERT_TRUE(r.vsBrute.has_value());
    EXPECT_EQ(r.vsBrute->relativeMse, run.vsBrute->relativeMse);
    EXPECT_EQ(r.vsBrute->ssim, run.vsBrute->ssim);
    EXPECT_EQ(r.vsBrute->meanAbsoluteError, run.vsBrute->meanAbsoluteError);
    EXPECT_EQ(r.vsBrute->maxAbsoluteError, run.vsBrute->maxAbsoluteError);
    EXPECT_EQ(r.vsBrute->psnr, run.vsBrute->psnr);
    EXPECT_EQ(r.vsBrute->pixelsCompared, run.vsBrute->pixelsCompared);
    EXPECT_FALSE(r.vsTruth.has_value());
    EXPECT_FALSE(r.vsFineBrute.has_value());
    EXPECT_TRUE(back.runs[1].isBrute);
    EXPECT_EQ(back.runs[1].method, "brute force");
    EXPECT_EQ(back.runs[1].config.channels, 1);
    ASSERT_EQ(back.temporal.size(), 1u);
    EXPECT_EQ(back.temporal[0].sequence, report.temporal[0].sequence);
    EXPECT_EQ(back.temporal[0].technique, report.temporal[0].technique);
    EXPECT_EQ(back.temporal[0].pointPairs, report.temporal[0].pointPairs);
    EXPECT_EQ(back.temporal[0].excessFlicker, report.temporal[0].excessFlicker);
    ASSERT_EQ(back.checks.size(), 1u);
    EXPECT_FALSE(back.checks[0].required);
    EXPECT_EQ(back.checks[0].detail, "reported only");

    // A required key missing: an error naming the file and the key, not a default.
    nlohmann::json j = readJson(dir / "bench-gather.json");
    j["runs"][0].erase("gpu_ms");
    std::ofstream(dir / "broken.json") << j.dump();
    lightskin::test::expectError([&] { lightskin::bench::readReport((dir / "broken.json").string()); },
                                 {(dir / "broken.json").string(), std::nullopt, "gpu_ms"});
}

// A stopped run's JSON says "status": "interrupted" and reads back so; a whole run's says "complete", and a file
// from before the key reads as complete. Its plots are not drawn (the run ends at once), stale ones removed.
TEST(BenchJson, AnInterruptedRunIsMarkedAndReadsBack) {
    const auto dir = scratchDir("bench_json_interrupted");
    Report report;
    report.bench = "bench-gather";
    report.interrupted = true;
    std::ofstream(dir / "bench-gather.png") << "an earlier run's plot";
    lightskin::bench::writeJsonAndPlots(report, dir.string());
    EXPECT_EQ(readJson(dir / "bench-gather.json").at("status"), "interrupted");
    EXPECT_TRUE(lightskin::bench::readReport((dir / "bench-gather.json").string()).interrupted);
    EXPECT_FALSE(std::filesystem::exists(dir / "bench-gather.png"));

    report.interrupted = false;
    lightskin::bench::writeJson(report, (dir / "complete.json").string());
    nlohmann::json j = readJson(dir / "complete.json");
    EXPECT_EQ(j.at("status"), "complete");
    j.erase("status");
    std::ofstream(dir / "older.json") << j.dump();
    EXPECT_FALSE(lightskin::bench::readReport((dir / "older.json").string()).interrupted);
}

TEST(BenchPlots, ThreeTechniquesKeepOneColourEachAcrossPlotsAndReadCleanly) {
    const auto dir = scratchDir("bench_plots_three_techniques");
    const Report report = threeTechniques();
    lightskin::bench::writeJson(report, (dir / "bench.json").string());
    const lightskin::bench::PlotOutcome outcome =
        lightskin::bench::drawPlots((dir / "bench.json").string(), dir.string());
    ASSERT_TRUE(outcome.drawn) << outcome.message << " (python3-matplotlib is in scripts/debian-packages.txt)";
    const nlohmann::json manifest = readJson(dir / "bench-plots.json");

    // One series per technique and backend, the PRT's key "multiscale-prt" shown by its name; 3 points each.
    const auto& pareto = manifest.at("bench.png").at("series");
    std::map<std::pair<std::string, std::string>, int> points;
    for (const auto& s : pareto) points[{s.at("method"), s.at("backend")}] = s.at("points").get<int>();
    const std::map<std::pair<std::string, std::string>, int> expected = {{{"LightSkin", "gl"}, 3},
                                                                         {{"LightSkin", "cpu"}, 3},
                                                                         {{"imperfect volumes", "gl"}, 3},
                                                                         {{"multi-scale PRT", "gl"}, 3},
                                                                         {{"brute force", "gl"}, 1}};
    EXPECT_EQ(points, expected);

    // Distinct colours and, between techniques, distinct markers.
    std::set<std::string> colours;
    std::map<std::string, std::set<std::string>> markers; // technique -> its markers
    for (const auto& s : pareto) {
        colours.insert(s.at("colour").get<std::string>());
        markers[s.at("method")].insert(s.at("marker").get<std::string>());
    }
    EXPECT_EQ(colours.size(), pareto.size());
    std::set<std::string> allMarkers;
    for (const auto& [method, m] : markers) {
        EXPECT_EQ(m.size(), 1u) << method << ": one marker per technique, whatever the backend";
        allMarkers.insert(m.begin(), m.end());
    }
    EXPECT_EQ(allMarkers.size(), markers.size());

    // Each technique's colour is in the Pareto image: 3 filled markers of ~60 px interior each, up to half
    // covered by neighbours or the default's ring, hence >= 30 px per point (the fixture test's bound).
    const cv::Mat image = cv::imread((dir / "bench.png").string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(image.empty());
    for (const auto& s : pareto) {
        if (s.at("colour") == "#000000") continue; // the brute force: text and axes are black too
        EXPECT_GE(pixelsOf(image, s.at("colour")), 30 * s.at("points").get<int>()) << s.at("method");
    }
    for (const char* plot : {"bench.png", "bench-vs-brute.png"})
        EXPECT_EQ(manifest.at(plot).at("label_overlaps").get<int>(), 0) << plot;

    // The same colour for a technique in the scaling plot (its three VAL counts, one line) ...
    const auto& scaling = manifest.at("bench-scaling.png").at("series");
    for (const auto& [key, n] : expected) {
        if (key.first == "brute force") continue;
        EXPECT_EQ(colourOf(scaling, key.first, key.second), colourOf(pareto, key.first, key.second)) << key.first;
        for (const auto& s : scaling)
            if (s.at("method") == key.first && s.at("backend") == key.second) {
                EXPECT_EQ(s.at("points"), n);
            }
    }
    // ... and in the flicker comparison (its rows name the PRT "multi-scale PRT": the same series).
    const auto& flicker = manifest.at("bench-flicker.png");
    const auto techniques = flicker.at("techniques").get<std::vector<std::string>>();
    const auto flickerColours = flicker.at("colours").get<std::vector<std::string>>();
    ASSERT_EQ(techniques.size(), 4u);
    const std::map<std::string, std::string> methodOfRow = {{"brute force (reference)", "brute force"},
                                                            {"lightskin, 1024 sparse", "LightSkin"},
                                                            {"imperfect volumes, 64^3", "imperfect volumes"},
                                                            {"multi-scale PRT, D 8", "multi-scale PRT"}};
    for (std::size_t i = 0; i < techniques.size(); ++i)
        EXPECT_EQ(flickerColours[i], colourOf(pareto, methodOfRow.at(techniques[i]), "gl")) << techniques[i];
}
