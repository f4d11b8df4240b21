// Outputs of `lightskin bench` (see BenchReport.h).
#include <lightskin/bench/BenchPlots.h>
#include <lightskin/bench/BenchReport.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/JsonError.h>
#include <lightskin/core/Log.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <thread>
#include <utility>

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

std::string errorCells(const std::optional<eval::ImageError>& e) {
    if (!e) return "- | -";
    return sci(e->relativeMse) + " | " + fixed(3, e->ssim);
}

} // namespace

std::string commandLine() {
    std::ifstream in("/proc/self/cmdline", std::ios::binary);
    std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()), out;
    std::size_t start = 0;
    bool first = true;
    while (start < all.size()) {
        const std::size_t end = std::min(all.find('\0', start), all.size());
        std::string word = all.substr(start, end - start);
        if (first) word = std::filesystem::path(word).filename().string();
        out += (first ? "" : " ") + word;
        first = false;
        start = end + 1;
    }
    return out;
}

std::string utcNow() {
    const std::time_t now = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&now, &tm);
    char buffer[64];
    std::strftime(buffer, sizeof buffer, "%Y-%m-%d %H:%M UTC", &tm);
    return buffer;
}

std::string machineDescription() {
    std::ifstream in("/proc/cpuinfo");
    std::string model = "unknown";
    for (std::string line; std::getline(in, line);)
        if (line.rfind("model name", 0) == 0) {
            const auto colon = line.find(':');
            if (colon != std::string::npos) model = line.substr(colon + 2);
            break;
        }
    return model + ", " + std::to_string(std::thread::hardware_concurrency()) + " threads";
}

std::string loadAverage() {
    std::ifstream in("/proc/loadavg");
    std::string one, five, fifteen;
    in >> one >> five >> fifteen;
    return one + " " + five + " " + fifteen;
}

Report startReport(std::string bench, int frames) {
    Report report;
    report.bench = std::move(bench);
    report.command = commandLine();
    report.date = utcNow();
    report.machine = machineDescription();
    report.loadStart = loadAverage();
    report.frames = frames;
    return report;
}

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

// ---- bench JSON (docs/bench/SCHEMA.md): every key is listed once, in fields(), for both directions ----

namespace {

/// Writes each visited field into a JSON object.
struct JsonWriter {
    nlohmann::json& j;
    template <typename T>
    void operator()(const char* key, const T& value) {
        j[key] = toJson(value);
    }
    /// Keys added after the first files were written: read with a fallback, written like the others.
    template <typename T>
    void withFallback(const char* key, const T& value, const T& /*fallback*/) {
        (*this)(key, value);
    }
    template <typename T>
    static nlohmann::json toJson(const T& value) {
        return value;
    }
    static nlohmann::json toJson(const std::optional<double>& value) {
        return value && std::isfinite(*value) ? nlohmann::json(*value) : nlohmann::json(nullptr);
    }
    static nlohmann::json toJson(const std::optional<eval::ImageError>& e) {
        if (!e) return nullptr;
        return {{"relative_mse", e->relativeMse},
                {"ssim", e->ssim},
                {"mae", e->meanAbsoluteError},
                {"max", e->maxAbsoluteError},
                {"psnr", toJson(std::optional<double>(e->psnr))}, // +inf (identical images): null
                {"pixels", e->pixelsCompared}};
    }
};

/// Reads each visited field from a JSON object (nlohmann's exceptions name a missing key or wrong type).
struct JsonReader {
    const nlohmann::json& j;
    template <typename T>
    void operator()(const char* key, T& value) {
        fromJson(j.at(key), value);
    }
    template <typename T>
    void withFallback(const char* key, T& value, const T& fallback) {
        if (j.contains(key))
            fromJson(j.at(key), value);
        else
            value = fallback;
    }
    template <typename T>
    static void fromJson(const nlohmann::json& x, T& value) {
        x.get_to(value);
    }
    static void fromJson(const nlohmann::json& x, std::optional<double>& value) {
        value = x.is_null() ? std::nullopt : std::optional<double>(x.get<double>());
    }
    static void fromJson(const nlohmann::json& x, std::optional<eval::ImageError>& value) {
        if (x.is_null()) {
            value.reset();
            return;
        }
        eval::ImageError e;
        e.relativeMse = x.at("relative_mse").get<double>();
        e.ssim = x.at("ssim").get<double>();
        e.meanAbsoluteError = x.at("mae").get<double>();
        e.maxAbsoluteError = x.at("max").get<double>();
        e.psnr = x.at("psnr").is_null() ? std::numeric_limits<double>::infinity() : x.at("psnr").get<double>();
        e.pixelsCompared = x.at("pixels").get<std::size_t>();
        value = e;
    }
};

template <typename Io, typename R>
void reportFields(Io& io, R& r) {
    io.withFallback("bench", r.bench, std::string("bench")); // files of `lightskin bench` before the key
    io("machine", r.machine);
    io("renderer", r.renderer);
    io("date", r.date);
    io("command", r.command);
    io("load_start", r.loadStart);
    io("load_end", r.loadEnd);
    io("truth_stride", r.truthStride);
    io("frames", r.frames);
    io("seconds", r.seconds);
    io("quick", r.quick);
}

template <typename Io, typename R>
void runFields(Io& io, R& r) {
    auto& c = r.config;
    io("axis", c.axis);
    io("value", c.value);
    io("is_default", c.isDefault);
    io("is_brute", r.isBrute);
    // Files from before the method/backend keys: the sweep's rows were LightSkin or brute force on GL.
    io.withFallback("method", r.method, std::string(r.isBrute ? "brute force" : "LightSkin"));
    io.withFallback("backend", r.backend, std::string(gi::toString(gi::Backend::Gl)));
    io.withFallback("series", r.series, std::string());
    io("sparse_per_model", c.sparse);
    io("val_stride", c.stride);
    io("vals", r.vals);
    io("kcache", c.kCache);
    io("width", c.width);
    io("height", c.height);
    io("triangles", r.triangles);
    io("adaptive", c.adaptive);
    io.withFallback("val_tree_threshold", c.valTree, 0.0f); // files without a tree threshold: the flat gather
    io("covered_pixels", r.covered);
    io("gpu_ms", r.gpuMs);
    io("cpu_ms", r.cpuMs);
    io("val_generation_ms", r.valsMs);
    io("prepare_ms", r.prepareMs);
    io("brute_ms", r.bruteMs);
    io("vs_brute", r.vsBrute);
    io("vs_truth", r.vsTruth);
    io.withFallback("vs_fine_brute", r.vsFineBrute, std::optional<eval::ImageError>());
    io.withFallback("brute_vs_fine_brute", r.bruteVsFineBrute, std::optional<eval::ImageError>());
    io("truth_receivers", r.truthReceivers);
}

template <typename Io, typename T>
void temporalFields(Io& io, T& t) {
    io("sequence", t.sequence);
    io("technique", t.technique);
    io("frames", t.frames);
    io("samples", t.pointPairs);
    io("flicker", t.flicker);
    io("reference_flicker", t.referenceFlicker);
    io("excess_flicker", t.excessFlicker);
    io.withFallback("method", t.method,
                    std::string(t.technique.starts_with("brute force") ? "brute force" : "LightSkin"));
    io.withFallback("backend", t.backend, std::string(gi::toString(gi::Backend::Gl)));
}

template <typename Io, typename C>
void checkFields(Io& io, C& c) {
    io("name", c.name);
    io("passed", c.passed);
    io.withFallback("required", c.required, true);
    io("detail", c.detail);
}

/// A run's fields that are not plain members: its label (written only), channels by name, stages.
nlohmann::json runToJson(const RunResult& r) {
    nlohmann::json j;
    JsonWriter w{j};
    runFields(w, r);
    j["label"] = label(r);
    j["channels"] = channelName(r.config.channels);
    for (const auto& s : r.stages) j["stages_ms"][s.first] = s.second;
    return j;
}

RunResult runFromJson(const nlohmann::json& j) {
    RunResult r;
    JsonReader reader{j};
    runFields(reader, r);
    const std::string channels = j.at("channels");
    r.config.channels = channels == "diffuse" ? 1 : channels == "+glossy" ? 2 : 3;
    // One spelling on read too: files from before it say "GL"/"CPU". The config's backend follows the row's.
    for (char& ch : r.backend) ch = char(std::tolower(static_cast<unsigned char>(ch)));
    r.config.backend = gi::parseBackend(r.backend).value_or(gi::Backend::Gl);
    if (j.contains("stages_ms"))
        for (const auto& [name, ms] : j.at("stages_ms").items()) r.stages.emplace_back(name, ms.get<double>());
    return r;
}

template <typename T, typename Fields>
nlohmann::json listToJson(const std::vector<T>& items, Fields fields) {
    nlohmann::json list = nlohmann::json::array();
    for (const T& item : items) {
        nlohmann::json j;
        JsonWriter w{j};
        fields(w, item);
        list.push_back(std::move(j));
    }
    return list;
}

template <typename T, typename Fields>
std::vector<T> listFromJson(const nlohmann::json& report, const char* key, Fields fields) {
    std::vector<T> items;
    for (const auto& j : report.value(key, nlohmann::json::array())) {
        T item;
        JsonReader reader{j};
        fields(reader, item);
        items.push_back(std::move(item));
    }
    return items;
}

} // namespace

void writeJson(const Report& report, const std::string& file) {
    nlohmann::json j;
    JsonWriter w{j};
    reportFields(w, report);
    j["status"] = report.interrupted ? "interrupted" : "complete";
    j["runs"] = nlohmann::json::array();
    for (const auto& r : report.runs) j["runs"].push_back(runToJson(r));
    j["temporal"] = listToJson(report.temporal, [](JsonWriter& io, const TemporalResult& t) { temporalFields(io, t); });
    j["checks"] = listToJson(report.checks, [](JsonWriter& io, const CheckResult& c) { checkFields(io, c); });
    std::ofstream out(file);
    if (!(out << j.dump(2) << "\n")) throw Error(file, std::nullopt, "cannot write the bench JSON");
}

Report readReport(const std::string& jsonFile) {
    std::ifstream in(jsonFile);
    if (!in) throw Error(jsonFile, std::nullopt, "cannot read the bench JSON");
    try {
        const nlohmann::json j = nlohmann::json::parse(in);
        Report r;
        JsonReader reader{j};
        reportFields(reader, r);
        r.interrupted = j.value("status", std::string("complete")) == "interrupted"; // older files: no status
        for (const auto& x : j.value("runs", nlohmann::json::array())) r.runs.push_back(runFromJson(x));
        r.temporal = listFromJson<TemporalResult>(j, "temporal", [](JsonReader& io, TemporalResult& t) {
            temporalFields(io, t);
            for (char& ch : t.backend) ch = char(std::tolower(static_cast<unsigned char>(ch))); // older files: "GL"
        });
        r.checks = listFromJson<CheckResult>(j, "checks", [](JsonReader& io, CheckResult& c) { checkFields(io, c); });
        return r;
    } catch (const nlohmann::json::exception& e) {
        throw Error(jsonFile, std::nullopt, "malformed bench JSON: " + jsonErrorCause(e.what()));
    }
}

std::string markdown(const Report& report) {
    std::ostringstream md;
    md << kBeginMarker << "\n";
    md << "## Speed against accuracy (`lightskin bench`)" << (report.quick ? " (quick run)" : "")
       << (report.interrupted ? " (interrupted: the rows measured before the stop)" : "") << "\n\n";
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
    std::ofstream(dir + "/bench.md") << markdown(report);
    writeJsonAndPlots(report, dir);
}

void writeJsonAndPlots(const Report& report, const std::string& dir) {
    std::filesystem::create_directories(dir);
    const std::string file = dir + "/" + report.bench + ".json";
    writeJson(report, file);
    log::info("results: " + file);
    if (report.interrupted) { // the user asked to stop: end now; the JSON holds everything the plots need
        removePlots(dir, report.bench);
        log::info("plots not drawn (interrupted run): bench/plots/bench_plots.py " + file + " " + dir + " draws them");
        return;
    }
    const PlotOutcome plots = drawPlots(file, dir, report.bench);
    if (plots.drawn)
        log::info(plots.message);
    else
        log::warning(plots.message);
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
