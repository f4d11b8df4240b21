// The plots of `lightskin bench` (bench/plots/bench_plots.py through bench::drawPlots) on a fixture
// bench.json with five (technique, backend) series: LightSkin on GL and on the CPU backend, the brute
// force, and rows standing in for imperfect volumes and multi-scale PRT (tests/bench/data: the GL rows
// are a real `bench --quick` run, the others are invented; plots only). The expectations are computed
// here from the fixture, independently of the script: which series exist and how many points each
// has, the Pareto front, and the colours found in the image.
#include "ExpectError.h"
#include "TestPaths.h"

#include <lightskin/bench/BenchPlots.h>
#include <lightskin/bench/BenchReport.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace {

using lightskin::test::scratchDir;
using Series = std::pair<std::string, std::string>; // (method, backend)

std::filesystem::path fixture() { return lightskin::test::sourceDir() / "tests/bench/data/bench-fixture.json"; }

nlohmann::json readJson(const std::filesystem::path& path) {
    std::ifstream in(path);
    return nlohmann::json::parse(in);
}

/// The rules of bench.json (BenchReport.h), restated: rows without method/backend are the sweep's own.
/// As the report reads a row: the backend in its one spelling ("gl"/"cpu"; older files say "GL"/"CPU").
Series seriesOf(const nlohmann::json& run) {
    const bool brute = run.at("is_brute").get<bool>();
    std::string backend = run.value("backend", std::string("gl"));
    for (char& ch : backend) ch = char(std::tolower(static_cast<unsigned char>(ch)));
    return {run.value("method", std::string(brute ? "brute force" : "LightSkin")), backend};
}

double timeOf(const nlohmann::json& run) {
    if (run.contains("time_ms") && !run.at("time_ms").is_null()) return run.at("time_ms").get<double>();
    const auto& t = run.at(run.at("is_brute").get<bool>() ? "brute_ms" : "gpu_ms");
    return t.is_null() ? 0.0 : t.get<double>();
}

struct Point {
    double time, error;
    std::string label;
    Series series;
    bool ownReference, filled;
};

/// The points of the error-against-truth plot, computed from the fixture.
std::vector<Point> truthPoints(const nlohmann::json& report) {
    std::string defaultChannels;
    for (const auto& r : report.at("runs"))
        if (r.at("is_default").get<bool>() && !r.at("is_brute").get<bool>()) defaultChannels = r.at("channels");
    std::vector<Point> points;
    for (const auto& r : report.at("runs")) {
        if (r.at("vs_truth").is_null()) continue;
        const double e = r.at("vs_truth").at("relative_mse").get<double>(), t = timeOf(r);
        if (e <= 0.0 || t <= 0.0) continue;
        const bool own = r.at("channels") == defaultChannels || r.at("is_brute").get<bool>();
        points.push_back({t, e, r.at("label"), seriesOf(r), own, own});
    }
    return points;
}

} // namespace

TEST(BenchPlots, DrawsOneSeriesPerTechniqueAndBackendWithTheParetoFrontAndNoOverlappingLabels) {
    const auto dir = scratchDir("bench_plots_fixture");
    const lightskin::bench::PlotOutcome outcome = lightskin::bench::drawPlots(fixture().string(), dir.string());
    ASSERT_TRUE(outcome.drawn) << outcome.message << " (python3-matplotlib is in scripts/debian-packages.txt)";
    const nlohmann::json report = readJson(fixture());
    const nlohmann::json manifest = readJson(dir / "bench-plots.json");

    // Every plot is a real image of the size the script asks for (10 x 6.2 in or 8 x 5.5 in at 110 dpi,
    // so at least 800 x 600 px), not an empty file.
    for (const char* name : {"bench.png", "bench-vs-brute.png", "bench-scaling.png", "bench-flicker.png"}) {
        const cv::Mat image = cv::imread((dir / name).string(), cv::IMREAD_COLOR);
        ASSERT_FALSE(image.empty()) << name;
        EXPECT_GE(image.cols, 800) << name;
        EXPECT_GE(image.rows, 600) << name;
    }

    // One series per (method, backend) in the fixture, with its number of points.
    const std::vector<Point> points = truthPoints(report);
    std::map<Series, int> expected, filled;
    for (const auto& p : points) {
        ++expected[p.series];
        if (p.filled) ++filled[p.series];
    }
    ASSERT_EQ(expected.size(), 5u) << "the fixture's five techniques/backends";
    std::map<Series, int> drawn;
    std::map<Series, std::string> colour;
    for (const auto& s : manifest.at("bench.png").at("series")) {
        const Series key{s.at("method"), s.at("backend")};
        drawn[key] = s.at("points").get<int>();
        colour[key] = s.at("colour");
    }
    EXPECT_EQ(drawn, expected);

    // Each series' colour is in the image. A filled marker (46 pt^2 at 110 dpi: ~10 px across) has ~60 px
    // of solid interior; neighbours may cover up to half of it, hence 30 px per filled marker. Black (the
    // brute force) is skipped: text and axes are black too.
    const cv::Mat image = cv::imread((dir / "bench.png").string(), cv::IMREAD_COLOR);
    for (const auto& [key, hex] : colour) {
        if (hex == "#000000") continue;
        const int r = std::stoi(hex.substr(1, 2), nullptr, 16), g = std::stoi(hex.substr(3, 2), nullptr, 16),
                  b = std::stoi(hex.substr(5, 2), nullptr, 16);
        int count = 0;
        for (int y = 0; y < image.rows; ++y)
            for (int x = 0; x < image.cols; ++x) {
                const cv::Vec3b p = image.at<cv::Vec3b>(y, x); // BGR
                if (std::abs(p[2] - r) <= 2 && std::abs(p[1] - g) <= 2 && std::abs(p[0] - b) <= 2) ++count;
            }
        EXPECT_GE(count, 30 * filled[key]) << key.first << " (" << key.second << ") colour " << hex;
    }

    // Pareto front over the points judged against the default's reference: sorted by time, each one
    // more accurate than every faster one.
    std::vector<Point> sorted;
    for (const auto& p : points)
        if (p.ownReference) sorted.push_back(p);
    std::stable_sort(sorted.begin(), sorted.end(), [](const Point& a, const Point& b) {
        return a.time < b.time || (a.time == b.time && a.error < b.error);
    });
    std::vector<std::string> front;
    double best = std::numeric_limits<double>::infinity();
    for (const auto& p : sorted)
        if (p.error < best) {
            best = p.error;
            front.push_back(p.label);
        }
    EXPECT_EQ(manifest.at("bench.png").at("pareto_front").get<std::vector<std::string>>(), front);

    // Readable labels: the default (and against the truth the brute force) is named, no two labels overlap, all inside
    // the image.
    for (const char* plot : {"bench.png", "bench-vs-brute.png"}) {
        const auto& labels = manifest.at(plot).at("labels");
        std::vector<std::string> texts;
        for (const auto& l : labels) {
            texts.push_back(l.at("text"));
            const auto box = l.at("box").get<std::vector<double>>();
            EXPECT_TRUE(box[0] >= 0 && box[1] >= 0 && box[2] <= image.cols && box[3] <= image.rows)
                << plot << " " << texts.back();
        }
        EXPECT_NE(std::find(texts.begin(), texts.end(), "default"), texts.end()) << plot;
        if (std::string(plot) == "bench.png") { // against the brute force, the brute force has no point
            EXPECT_NE(std::find(texts.begin(), texts.end(), "brute force"), texts.end()) << plot;
        }
        EXPECT_EQ(manifest.at(plot).at("label_overlaps").get<int>(), 0) << plot;
    }

    // The flicker comparison has every sequence and technique of the fixture's temporal rows.
    std::vector<std::string> sequences, techniques;
    for (const auto& t : report.at("temporal")) {
        if (std::find(sequences.begin(), sequences.end(), t.at("sequence")) == sequences.end())
            sequences.push_back(t.at("sequence"));
        if (std::find(techniques.begin(), techniques.end(), t.at("technique")) == techniques.end())
            techniques.push_back(t.at("technique"));
    }
    EXPECT_EQ(manifest.at("bench-flicker.png").at("sequences").get<std::vector<std::string>>(), sequences);
    EXPECT_EQ(manifest.at("bench-flicker.png").at("techniques").get<std::vector<std::string>>(), techniques);
}

TEST(BenchPlots, SkipsWithAMessageThatSaysHowToGetThePlotsWhenMatplotlibOrPythonIsMissing) {
    const auto dir = scratchDir("bench_plots_skipped");
    // A Python without site packages (-S) stands in for a machine without python3-matplotlib.
    const auto wrapper = dir / "python-without-matplotlib";
    std::ofstream(wrapper) << "#!/bin/sh\nexec /usr/bin/python3 -S \"$@\"\n";
    std::filesystem::permissions(wrapper, std::filesystem::perms::owner_all);
    std::ofstream(dir / "bench.png") << "stale plot of an earlier run";
    ASSERT_EQ(setenv("LIGHTSKIN_PYTHON", wrapper.c_str(), 1), 0);
    const auto noMatplotlib = lightskin::bench::drawPlots(fixture().string(), dir.string());
    ASSERT_EQ(setenv("LIGHTSKIN_PYTHON", (dir / "no-such-python").c_str(), 1), 0);
    const auto noPython = lightskin::bench::drawPlots(fixture().string(), dir.string());
    unsetenv("LIGHTSKIN_PYTHON");

    EXPECT_FALSE(noMatplotlib.drawn);
    EXPECT_NE(noMatplotlib.message.find("python3-matplotlib is not installed"), std::string::npos)
        << noMatplotlib.message;
    EXPECT_NE(noMatplotlib.message.find("--from-json " + fixture().string()), std::string::npos)
        << noMatplotlib.message;
    EXPECT_FALSE(noPython.drawn);
    EXPECT_NE(noPython.message.find("python3 is not installed"), std::string::npos) << noPython.message;
    EXPECT_FALSE(std::filesystem::exists(dir / "bench.png")) << "a stale plot would pass for this run's";
}

TEST(BenchPlots, NamesTheFileWhenTheJsonIsNotABenchReport) {
    const auto dir = scratchDir("bench_plots_bad");
    std::ofstream(dir / "bad.json") << "{\"runs\": [{\"label\": \"x\"}]}";
    lightskin::test::expectError([&] { lightskin::bench::drawPlots((dir / "bad.json").string(), dir.string()); },
                                 {"bad.json", std::nullopt, "rejected this file"});
}

TEST(BenchReport, KeepsMethodAndBackendThroughJsonAndDrawsThePlotsOnWrite) {
    const nlohmann::json fixtureJson = readJson(fixture());
    std::vector<Series> expected;
    for (const auto& r : fixtureJson.at("runs")) expected.push_back(seriesOf(r));

    const auto dir = scratchDir("bench_report_roundtrip");
    lightskin::bench::writeOutputs(lightskin::bench::readReport(fixture().string()), dir.string());
    const lightskin::bench::Report again = lightskin::bench::readReport((dir / "bench.json").string());
    std::vector<Series> read;
    for (const auto& r : again.runs) read.emplace_back(r.method, r.backend);
    EXPECT_EQ(read, expected);
    EXPECT_EQ(again.temporal.size(), fixtureJson.at("temporal").size());
    EXPECT_TRUE(std::filesystem::exists(dir / "bench.md"));
    EXPECT_TRUE(std::filesystem::exists(dir / "bench.png"));
}
