// Outputs of `lightskin bench` (see BenchReport.h).
#include <lightskin/bench/BenchReport.h>
#include <lightskin/core/Error.h>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

namespace lightskin::bench {

namespace {

constexpr const char* kBeginMarker = "<!-- lightskin-bench:begin -->";
constexpr const char* kEndMarker = "<!-- lightskin-bench:end -->";

std::string label(const RunResult& r) {
    if (r.isBrute) return "brute force";
    return r.config.axis == "default" ? std::string("default") : r.config.axis + "=" + r.config.value;
}

std::string fixed(int digits, double value) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.*f", digits, value);
    return buffer;
}

std::string sci(double value) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.2e", value);
    return buffer;
}

std::string general(double value) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%g", value);
    return buffer;
}

std::vector<std::string> stageNames(const Report& report) {
    std::vector<std::string> names;
    for (const auto& r : report.runs)
        for (const auto& s : r.stages)
            if (std::find(names.begin(), names.end(), s.first) == names.end()) names.push_back(s.first);
    return names;
}

double stage(const RunResult& r, const std::string& name) {
    for (const auto& s : r.stages)
        if (s.first == name) return s.second;
    return std::numeric_limits<double>::quiet_NaN();
}

nlohmann::json errorJson(const std::optional<eval::ImageError>& e) {
    if (!e) return nullptr;
    return {{"relative_mse", e->relativeMse},
            {"ssim", e->ssim},
            {"mae", e->meanAbsoluteError},
            {"max", e->maxAbsoluteError},
            {"psnr", std::isfinite(e->psnr) ? nlohmann::json(e->psnr) : nlohmann::json(nullptr)},
            {"pixels", e->pixelsCompared}};
}

/// The error plotted for a run: against the ground truth or against the brute force on the same VALs.
std::optional<double> plottedError(const RunResult& r, bool truth) {
    const auto& e = truth ? r.vsTruth : r.vsBrute;
    if (e && e->relativeMse > 0.0) return e->relativeMse;
    return std::nullopt;
}

void drawPlot(const Report& report, const std::string& path, bool truth) {
    struct Point {
        double time, error;
        const RunResult* run;
    };
    int defaultChannels = 3;
    for (const auto& r : report.runs)
        if (r.config.isDefault) defaultChannels = r.config.channels;
    std::vector<Point> points;
    for (const auto& r : report.runs) {
        const auto e = plottedError(r, truth);
        const double t = r.isBrute ? r.bruteMs.value_or(0.0) : r.gpuMs;
        if (e && t > 0.0) points.push_back({t, *e, &r});
    }
    const int W = 1100, H = 650, left = 90, right = 130, top = 50, bottom = 70;
    cv::Mat image(H, W, CV_8UC3, cv::Scalar(255, 255, 255));
    cv::putText(
        image,
        truth ? "lightskin bench: error vs ray-traced ground truth (relative MSE) against GPU time per frame"
              : "lightskin bench: error vs brute force on the same VALs (relative MSE) against GPU time per frame",
        {left, 30}, cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    if (points.empty()) {
        cv::imwrite(path, image);
        return;
    }
    double tMin = 1e300, tMax = 0, eMin = 1e300, eMax = 0;
    for (const auto& p : points) {
        tMin = std::min(tMin, p.time);
        tMax = std::max(tMax, p.time);
        eMin = std::min(eMin, p.error);
        eMax = std::max(eMax, p.error);
    }
    const double x0 = std::floor(std::log10(tMin)), x1 = std::max(x0 + 1, std::ceil(std::log10(tMax)));
    const double y0 = std::floor(std::log10(eMin)), y1 = std::max(y0 + 1, std::ceil(std::log10(eMax)));
    const auto px = [&](double t) {
        return left + int(std::lround((std::log10(t) - x0) / (x1 - x0) * (W - left - right)));
    };
    const auto py = [&](double e) {
        return H - bottom - int(std::lround((std::log10(e) - y0) / (y1 - y0) * (H - top - bottom)));
    };
    const cv::Scalar grid(220, 220, 220), black(0, 0, 0);
    for (double d = x0; d <= x1 + 1e-9; d += 1) {
        for (int m = 1; m < 10 && d + std::log10(m) <= x1 + 1e-9; ++m) {
            const int x = px(std::pow(10.0, d) * m);
            cv::line(image, {x, top}, {x, H - bottom}, m == 1 ? cv::Scalar(180, 180, 180) : grid, 1);
        }
        cv::putText(image, general(std::pow(10.0, d)) + " ms", {px(std::pow(10.0, d)) - 20, H - bottom + 20},
                    cv::FONT_HERSHEY_SIMPLEX, 0.45, black, 1, cv::LINE_AA);
    }
    for (double d = y0; d <= y1 + 1e-9; d += 1) {
        for (int m = 1; m < 10 && d + std::log10(m) <= y1 + 1e-9; ++m) {
            const int y = py(std::pow(10.0, d) * m);
            cv::line(image, {left, y}, {W - right, y}, m == 1 ? cv::Scalar(180, 180, 180) : grid, 1);
        }
        cv::putText(image, "1e" + fixed(0, d), {10, py(std::pow(10.0, d)) + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.45, black,
                    1, cv::LINE_AA);
    }
    cv::rectangle(image, {left, top}, {W - right, H - bottom}, black, 1);
    cv::putText(image, "GPU time per frame (ms, log)", {W / 2 - 120, H - 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, black, 1,
                cv::LINE_AA);
    cv::putText(image, "rel. MSE", {10, top - 8}, cv::FONT_HERSHEY_SIMPLEX, 0.45, black, 1, cv::LINE_AA);

    // Pareto front: no other point is both faster and more accurate.
    std::vector<Point> sorted = points;
    std::sort(sorted.begin(), sorted.end(), [](const Point& a, const Point& b) { return a.time < b.time; });
    std::vector<cv::Point> front;
    double best = std::numeric_limits<double>::infinity();
    std::set<const RunResult*> onFront;
    for (const auto& p : sorted)
        if (p.run->config.channels == defaultChannels && p.error < best) {
            best = p.error;
            front.emplace_back(px(p.time), py(p.error));
            onFront.insert(p.run);
        }
    for (std::size_t i = 1; i < front.size(); ++i)
        cv::line(image, front[i - 1], front[i], cv::Scalar(200, 120, 0), 2, cv::LINE_AA);
    for (const auto& p : points) {
        const cv::Point c(px(p.time), py(p.error));
        const bool pareto = onFront.count(p.run) != 0;
        if (p.run->isBrute)
            cv::rectangle(image, c - cv::Point(5, 5), c + cv::Point(5, 5), black, cv::FILLED);
        else if (p.run->config.channels != defaultChannels) // another reference (diffuse-only truth etc.)
            cv::circle(image, c, 5, cv::Scalar(150, 150, 150), 1, cv::LINE_AA);
        else
            cv::circle(image, c, 5, pareto ? cv::Scalar(200, 120, 0) : cv::Scalar(150, 150, 150), cv::FILLED,
                       cv::LINE_AA);
        if (p.run->config.isDefault && !p.run->isBrute) cv::circle(image, c, 10, cv::Scalar(0, 0, 230), 2, cv::LINE_AA);
        cv::putText(image, label(*p.run), c + cv::Point(8, -6), cv::FONT_HERSHEY_SIMPLEX, 0.35, cv::Scalar(60, 60, 60),
                    1, cv::LINE_AA);
    }
    const int ly = top + 15;
    cv::circle(image, {W - right - 230, ly}, 5, cv::Scalar(200, 120, 0), cv::FILLED);
    cv::putText(image, "Pareto front", {W - right - 218, ly + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4, black, 1, cv::LINE_AA);
    cv::circle(image, {W - right - 230, ly + 18}, 9, cv::Scalar(0, 0, 230), 2);
    cv::putText(image, "default configuration", {W - right - 218, ly + 22}, cv::FONT_HERSHEY_SIMPLEX, 0.4, black, 1,
                cv::LINE_AA);
    cv::rectangle(image, {W - right - 235, ly + 31}, {W - right - 225, ly + 41}, black, cv::FILLED);
    cv::putText(image, "brute force (no visibility)", {W - right - 218, ly + 40}, cv::FONT_HERSHEY_SIMPLEX, 0.4, black,
                1, cv::LINE_AA);
    cv::circle(image, {W - right - 230, ly + 54}, 5, cv::Scalar(150, 150, 150), 1, cv::LINE_AA);
    cv::putText(image, "other channels (own reference)", {W - right - 218, ly + 58}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
                black, 1, cv::LINE_AA);
    if (!cv::imwrite(path, image)) throw Error(path, std::nullopt, "cannot write the plot");
}

std::string errorCells(const std::optional<eval::ImageError>& e) {
    if (!e) return "- | -";
    return sci(e->relativeMse) + " | " + fixed(3, e->ssim);
}

} // namespace

const char* channelName(int channels) {
    switch (channels) {
    case 1:
        return "diffuse";
    case 2:
        return "+glossy";
    default:
        return "+occlusion";
    }
}

std::string markdown(const Report& report) {
    std::ostringstream md;
    md << kBeginMarker << "\n";
    md << "## Speed against accuracy (`lightskin bench`)" << (report.quick ? " (quick run)" : "") << "\n\n";
    md << "Generated by `lightskin bench`; regenerate with the command below (do not edit between the markers).\n\n";
    md << "- Command: `" << report.command << "`\n";
    md << "- Date: " << report.date << "; run time " << fixed(0, report.seconds) << " s\n";
    md << "- Machine: " << report.machine << "; load average (1/5/15 min) at start " << report.loadStart << ", at end "
       << report.loadEnd << "\n";
    md << "- Renderer: " << report.renderer << "\n";
    md << "- Times: median of " << report.frames
       << " frames after one warm-up frame; GPU = sum of the technique's GL timer-query stages (VAL generation "
          "listed separately, it is common to every technique); CPU = wall time of render() + glFinish. Brute force: "
          "one frame.\n";
    md << "- Errors (linear radiance of the indirect light on the virtual objects): `vs brute` = against the brute "
          "force on the same VALs, G-buffer and frame (all covered pixels); `vs truth` = against the Embree ground "
          "truth with visibility (disc-centre visibility and the paper's disc form factor) from the stride-"
       << report.truthStride
       << " VAL map of the same depth frame, at a grid of receiver pixels. rel. MSE = mean((x-r)^2/(r^2+0.01)), "
          "`vs fine brute` = against the brute force on the stride-"
       << report.truthStride
       << " VAL map (the finest of the truth) with the same reflectance model: VAL stride plus approximation. "
          "SSIM on the image scaled to the reference's maximum, MAE and max in W/(sr m^2).\n\n";
    const auto stages = stageNames(report);
    md << "| configuration | VALs | sparse/model | triangles | output | GPU ms | CPU ms | VAL gen ms |";
    for (const auto& s : stages) md << " " << s << " |";
    md << " brute ms | speed-up | rel. MSE vs brute | SSIM vs brute | rel. MSE vs fine brute | rel. MSE vs truth | "
          "SSIM vs truth | MAE vs truth | max vs truth |\n";
    md << "|---|---|---|---|---|---|---|---|";
    for (std::size_t i = 0; i < stages.size(); ++i) md << "---|";
    md << "---|---|---|---|---|---|---|---|---|\n";
    for (const auto& r : report.runs) {
        const auto& c = r.config;
        md << "| " << (c.isDefault && !r.isBrute ? "**" + label(r) + "**" : label(r)) << " | " << r.vals << " | "
           << (r.isBrute ? std::string("-") : std::to_string(c.sparse)) << " | " << r.triangles << " | " << c.width
           << "x" << c.height << " | ";
        if (r.isBrute) {
            md << fixed(1, r.bruteMs.value_or(0.0)) << " | - | " << fixed(1, r.valsMs) << " |";
            for (std::size_t i = 0; i < stages.size(); ++i) md << " |";
            md << " " << fixed(1, r.bruteMs.value_or(0.0)) << " | 1x | - | - | - | ";
        } else {
            md << fixed(1, r.gpuMs) << " | " << fixed(1, r.cpuMs) << " | " << fixed(1, r.valsMs) << " |";
            for (const auto& s : stages) {
                const double v = stage(r, s);
                md << " " << (std::isnan(v) ? std::string("-") : fixed(1, v)) << " |";
            }
            md << " " << (r.bruteMs ? fixed(0, *r.bruteMs) : std::string("-")) << " | "
               << (r.bruteMs ? fixed(0, *r.bruteMs / r.gpuMs) + "x" : std::string("-")) << " | "
               << errorCells(r.vsBrute) << " | " << (r.vsFineBrute ? sci(r.vsFineBrute->relativeMse) : std::string("-"))
               << " | ";
        }
        md << errorCells(r.vsTruth) << " | " << (r.vsTruth ? sci(r.vsTruth->meanAbsoluteError) : "-") << " | "
           << (r.vsTruth ? sci(r.vsTruth->maxAbsoluteError) : "-") << " |\n";
    }
    if (!report.temporal.empty()) {
        md << "\n### Temporal stability\n\n";
        md << "Diffuse channel (with occlusion when the default has it) on both sides, so that the true change "
              "under a moving camera is zero. Flicker = RMS over tracked surface points and consecutive frame pairs of "
              "the frame-to-frame change of the "
              "indirect radiance (mean of RGB) at the same surface point, divided by the mean reference radiance "
              "there. "
              "Points: mesh vertices projected with the known poses into each frame, kept where the G-buffer position "
              "matches the vertex within 1 cm and both frames see it. Reference = brute force on the same VALs (it has "
              "the same sampling of the surface points, so its flicker is the floor set by the scene and the "
              "re-projection). Excess = RMS of (our change - reference change) / mean reference radiance: the change "
              "the approximation adds. Sequences: `camera` = moving view camera, static light and content (the "
              "reference's change is only the re-projection to the nearest pixel); `light` = a bright patch moving "
              "across the real wall (moving light); `edges` = the depth camera moving sideways so VALs appear and "
              "disappear at the real box's depth edges.\n\n";
        md << "| sequence | technique | frames | samples | flicker | reference flicker | excess flicker "
              "|\n|---|---|---|---|---|---|---|\n";
        for (const auto& t : report.temporal)
            md << "| " << t.sequence << " | " << t.technique << " | " << t.frames << " | " << t.pointPairs << " | "
               << fixed(4, t.flicker) << " | " << fixed(4, t.referenceFlicker) << " | " << fixed(4, t.excessFlicker)
               << " |\n";
    }
    if (!report.checks.empty()) {
        md << "\n### Checks\n\n";
        for (const auto& c : report.checks)
            md << "- "
               << (c.passed     ? "PASS"
                   : c.required ? "FAIL"
                                : "does not hold (reported only)")
               << " " << c.name << ": " << c.detail << "\n";
    }
    md << kEndMarker << "\n";
    return md.str();
}

void writeOutputs(const Report& report, const std::string& dir) {
    std::filesystem::create_directories(dir);
    const auto stages = stageNames(report);
    {
        std::ofstream csv(dir + "/bench.csv");
        csv << "label,axis,value,is_default,is_brute,sparse_per_model,val_stride,vals,kcache,channels,width,height,"
               "triangles,adaptive,covered_pixels,gpu_ms,cpu_ms,val_generation_ms,prepare_ms";
        for (const auto& s : stages) csv << ",stage_" << s << "_ms";
        csv << ",brute_ms,speedup,brute_relmse,brute_ssim,brute_mae,brute_max,truth_relmse,truth_ssim,truth_mae,truth_"
               "max,"
               "truth_receivers,fine_brute_relmse,fine_brute_ssim\n";
        for (const auto& r : report.runs) {
            const auto& c = r.config;
            csv << '"' << label(r) << "\"," << c.axis << ',' << c.value << ',' << c.isDefault << ',' << r.isBrute << ','
                << c.sparse << ',' << c.stride << ',' << r.vals << ',' << c.kCache << ',' << channelName(c.channels)
                << ',' << c.width << ',' << c.height << ',' << r.triangles << ',' << c.adaptive << ',' << r.covered
                << ',' << r.gpuMs << ',' << r.cpuMs << ',' << r.valsMs << ',' << r.prepareMs;
            for (const auto& s : stages) {
                const double v = stage(r, s);
                csv << ',';
                if (!std::isnan(v)) csv << v;
            }
            csv << ',';
            if (r.bruteMs)
                csv << *r.bruteMs << ',' << (r.isBrute ? 1.0 : *r.bruteMs / r.gpuMs);
            else
                csv << ',';
            for (const auto* e : {&r.vsBrute, &r.vsTruth}) {
                if (*e)
                    csv << ',' << (*e)->relativeMse << ',' << (*e)->ssim << ',' << (*e)->meanAbsoluteError << ','
                        << (*e)->maxAbsoluteError;
                else
                    csv << ",,,,";
            }
            csv << ',' << r.truthReceivers << ',';
            if (r.vsFineBrute)
                csv << r.vsFineBrute->relativeMse << ',' << r.vsFineBrute->ssim;
            else
                csv << ',';
            csv << '\n';
        }
    }
    {
        nlohmann::json j;
        j["machine"] = report.machine;
        j["renderer"] = report.renderer;
        j["date"] = report.date;
        j["command"] = report.command;
        j["load_start"] = report.loadStart;
        j["load_end"] = report.loadEnd;
        j["truth_stride"] = report.truthStride;
        j["frames"] = report.frames;
        j["seconds"] = report.seconds;
        j["quick"] = report.quick;
        for (const auto& r : report.runs) {
            const auto& c = r.config;
            nlohmann::json run = {{"label", label(r)},
                                  {"axis", c.axis},
                                  {"value", c.value},
                                  {"is_default", c.isDefault},
                                  {"is_brute", r.isBrute},
                                  {"sparse_per_model", c.sparse},
                                  {"val_stride", c.stride},
                                  {"vals", r.vals},
                                  {"kcache", c.kCache},
                                  {"channels", channelName(c.channels)},
                                  {"width", c.width},
                                  {"height", c.height},
                                  {"triangles", r.triangles},
                                  {"adaptive", c.adaptive},
                                  {"covered_pixels", r.covered},
                                  {"gpu_ms", r.gpuMs},
                                  {"cpu_ms", r.cpuMs},
                                  {"val_generation_ms", r.valsMs},
                                  {"prepare_ms", r.prepareMs},
                                  {"brute_ms", r.bruteMs ? nlohmann::json(*r.bruteMs) : nlohmann::json(nullptr)},
                                  {"vs_brute", errorJson(r.vsBrute)},
                                  {"vs_truth", errorJson(r.vsTruth)},
                                  {"vs_fine_brute", errorJson(r.vsFineBrute)},
                                  {"truth_receivers", r.truthReceivers}};
            for (const auto& s : r.stages) run["stages_ms"][s.first] = s.second;
            j["runs"].push_back(run);
        }
        for (const auto& t : report.temporal)
            j["temporal"].push_back({{"sequence", t.sequence},
                                     {"technique", t.technique},
                                     {"frames", t.frames},
                                     {"samples", t.pointPairs},
                                     {"flicker", t.flicker},
                                     {"reference_flicker", t.referenceFlicker},
                                     {"excess_flicker", t.excessFlicker}});
        for (const auto& c : report.checks)
            j["checks"].push_back(
                {{"name", c.name}, {"passed", c.passed}, {"required", c.required}, {"detail", c.detail}});
        std::ofstream(dir + "/bench.json") << j.dump(2) << "\n";
    }
    drawPlot(report, dir + "/bench.png", true);
    drawPlot(report, dir + "/bench-vs-brute.png", false);
    std::ofstream(dir + "/bench.md") << markdown(report);
}

namespace {

std::optional<eval::ImageError> errorFromJson(const nlohmann::json& j) {
    if (j.is_null()) return std::nullopt;
    eval::ImageError e;
    e.relativeMse = j.at("relative_mse").get<double>();
    e.ssim = j.at("ssim").get<double>();
    e.meanAbsoluteError = j.at("mae").get<double>();
    e.maxAbsoluteError = j.at("max").get<double>();
    e.psnr = j.at("psnr").is_null() ? std::numeric_limits<double>::infinity() : j.at("psnr").get<double>();
    e.pixelsCompared = j.at("pixels").get<std::size_t>();
    return e;
}

} // namespace

Report readReport(const std::string& jsonFile) {
    std::ifstream in(jsonFile);
    if (!in) throw Error(jsonFile, std::nullopt, "cannot read the bench JSON");
    try {
        const nlohmann::json j = nlohmann::json::parse(in);
        Report r;
        r.machine = j.at("machine");
        r.renderer = j.at("renderer");
        r.date = j.at("date");
        r.command = j.at("command");
        r.loadStart = j.at("load_start");
        r.loadEnd = j.at("load_end");
        r.truthStride = j.at("truth_stride");
        r.frames = j.at("frames");
        r.seconds = j.at("seconds");
        r.quick = j.at("quick");
        for (const auto& x : j.value("runs", nlohmann::json::array())) {
            RunResult run;
            Config& c = run.config;
            c.axis = x.at("axis");
            c.value = x.at("value");
            c.isDefault = x.at("is_default");
            run.isBrute = x.at("is_brute");
            c.sparse = x.at("sparse_per_model");
            c.stride = x.at("val_stride");
            c.kCache = x.at("kcache");
            const std::string channels = x.at("channels");
            c.channels = channels == "diffuse" ? 1 : channels == "+glossy" ? 2 : 3;
            c.width = x.at("width");
            c.height = x.at("height");
            c.adaptive = x.at("adaptive");
            run.vals = x.at("vals");
            run.triangles = x.at("triangles");
            run.covered = x.at("covered_pixels");
            run.gpuMs = x.at("gpu_ms");
            run.cpuMs = x.at("cpu_ms");
            run.valsMs = x.at("val_generation_ms");
            run.prepareMs = x.at("prepare_ms");
            if (!x.at("brute_ms").is_null()) run.bruteMs = x.at("brute_ms").get<double>();
            run.vsBrute = errorFromJson(x.at("vs_brute"));
            run.vsTruth = errorFromJson(x.at("vs_truth"));
            run.vsFineBrute = errorFromJson(x.value("vs_fine_brute", nlohmann::json()));
            run.truthReceivers = x.at("truth_receivers");
            if (x.contains("stages_ms"))
                for (const auto& [name, ms] : x.at("stages_ms").items())
                    run.stages.emplace_back(name, ms.get<double>());
            r.runs.push_back(std::move(run));
        }
        for (const auto& x : j.value("temporal", nlohmann::json::array()))
            r.temporal.push_back({x.at("sequence"), x.at("technique"), x.at("frames"), x.at("samples"), x.at("flicker"),
                                  x.at("reference_flicker"), x.at("excess_flicker")});
        for (const auto& x : j.value("checks", nlohmann::json::array())) {
            CheckResult c;
            c.name = x.at("name");
            c.passed = x.at("passed");
            c.required = x.value("required", true);
            c.detail = x.at("detail");
            r.checks.push_back(c);
        }
        return r;
    } catch (const nlohmann::json::exception& e) {
        throw Error(jsonFile, std::nullopt, std::string("malformed bench JSON: ") + e.what());
    }
}

void regenerateDocs(const Report& report, const std::string& docsFile) {
    std::string text;
    {
        std::ifstream in(docsFile);
        if (!in) throw Error(docsFile, std::nullopt, "cannot read the docs file");
        std::ostringstream s;
        s << in.rdbuf();
        text = s.str();
    }
    const std::string section = markdown(report);
    const auto begin = text.find(kBeginMarker), end = text.find(kEndMarker);
    if (begin != std::string::npos && end != std::string::npos && end > begin) {
        std::size_t after = end + std::string(kEndMarker).size();
        if (after < text.size() && text[after] == '\n') ++after;
        text = text.substr(0, begin) + section + text.substr(after);
    } else {
        text += "\n" + section;
    }
    std::ofstream out(docsFile);
    if (!(out << text)) throw Error(docsFile, std::nullopt, "cannot write the docs file");
}

} // namespace lightskin::bench
