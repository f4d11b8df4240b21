// `lightskin replay <recording>`: the main job. Reads every frame of a recording (any FrameSource),
// places the scene's virtual content with the recorded or tracked pose, lights it with direct
// light and the GI technique, composites it over the colour image and writes PNGs, a video and
// a report (JSON + Markdown). Headless (EGL) unless --window. Ctrl-C or SIGTERM stops after the
// current frame and keeps everything written so far (video finalised, report marked "interrupted";
// exit 130 or 143).
#include "CliSupport.h"
#include "Commands.h"
#include "LiveWindowDisplay.h"
#include "PoseLabel.h"
#include "ReplayReport.h"
#include "RoomModelOptions.h"
#include "SceneInputs.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/eval/GoldenImage.h>
#include <lightskin/gi/common/Technique.h>
#include <lightskin/gl/Context.h>
#include <lightskin/gl/DebugOutput.h>
#include <lightskin/mr/Session.h>
#include <lightskin/render/Scene.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <numbers>
#include <set>
#include <sstream>
#include <string>
#include <unistd.h>
#include <utility>
#include <vector>

namespace lightskin::apps {

namespace {

/// The backend settings' spellings as the registry has them (gi/common/Technique.h), for --backend's check.
std::vector<std::string> backendSpellings() {
    std::vector<std::string> spellings;
    for (const gi::BackendSetting setting : gi::kBackendSettings) spellings.emplace_back(gi::toString(setting));
    return spellings;
}

struct CompareLabels {
    std::string left, right; ///< the halves' labels
    std::string title;       ///< report.md's heading for the images
    std::string folder;      ///< under --out: "compare" for the final view, "compare-<view>" for another
};

/// What the side-by-side images of `--view view` show (see where it is used).
CompareLabels compareLabels(const std::string& view, const std::string& technique) {
    if (view == "final")
        return {"with GI (" + technique + ")", "without GI", "With GI / without GI (the paper's figure 4)", "compare"};
    const std::string folder = "compare-" + view;
    if (view == "direct" || view == "indirect" || view == "normals" || view == "albedo")
        return {view + " view, with GI (" + technique + ")", view + " view, without GI",
                "The " + view + " view with GI / without GI", folder};
    const std::string what = view == "vals"           ? "VALs by flux"
                             : view == "sparse"       ? "sparse points"
                             : view == "error"        ? "error against brute force"
                             : view == "vpl"          ? "per-vertex VPLs"
                             : view == "differential" ? "differential shading"
                             : view == "light"        ? "the room's estimated light"
                                                      : view;
    return {what + " over the composite", "composite without GI",
            "The " + what + " drawn over the composite / the composite without GI", folder};
}

struct ReplayArgs {
    std::string recording, scene, out = "replay-out", writeFrames = "all", pose, view = "final", videoFormat = "auto";
    bool overwrite = false, window = false, noVideo = false, sideBySideVideo = false, noCompare = false;
    bool adaptive = false, linearOut = false, rawDepth = false, sequential = false;
    float staticTolerance = 0.0f;
    double budgetMs = 0.0; ///< --budget-ms (0: the scene's gi.budgetMs, if any)
    std::string staticTest = "probes";
    std::string backend; ///< overrides the scene's gi.backend when set (auto, gl, cpu)
    std::string differential = "scene";
    std::string cacheDir;                  ///< --cache-dir: overrides the scene's multi-scale PRT cache folder when set
    RoomModelOptions roomModel;            ///< --room-model, --save-room-model
    std::optional<std::int64_t> maxFrames; ///< --max-frames (>= 1); all frames when unset
};

/// Error of two composites against the objects-present truth (synth/present, see ReplayReport.h).
void presentErrorInto(const cv::Mat& truth, const cv::Mat& camera, const cv::Mat& withDifferential,
                      const cv::Mat& withoutDifferential, ReportFrame& rf) {
    static const std::array<double, 256> decoded = [] {
        std::array<double, 256> table{};
        for (std::size_t i = 0; i < table.size(); ++i) {
            const double c = double(i) / 255.0;
            table[i] = c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
        }
        return table;
    }();
    struct Sums {
        std::int64_t pixels = 0;
        double absWith = 0.0, absWithout = 0.0, sqWith = 0.0, sqWithout = 0.0;
    } all, real;
    for (int v = 0; v < truth.rows; ++v)
        for (int u = 0; u < truth.cols; ++u) {
            const cv::Vec3b t = truth.at<cv::Vec3b>(v, u), c = camera.at<cv::Vec3b>(v, u),
                            a = withDifferential.at<cv::Vec3b>(v, u), b = withoutDifferential.at<cv::Vec3b>(v, u);
            if (t == c && b == c) continue; // neither the truth nor the virtual content changes this pixel
            const bool covered = b != c;    // virtual content (without the differential, only it changes pixels)
            for (Sums* sums : {&all, covered ? nullptr : &real}) {
                if (sums == nullptr) continue;
                ++sums->pixels;
                for (int k = 0; k < 3; ++k) {
                    const double ea = decoded[a[k]] - decoded[t[k]], eb = decoded[b[k]] - decoded[t[k]];
                    sums->absWith += std::abs(ea);
                    sums->absWithout += std::abs(eb);
                    sums->sqWith += ea * ea;
                    sums->sqWithout += eb * eb;
                }
            }
        }
    const auto finish = [](const Sums& s, ReportFrame::PresentError& e) {
        e.pixels = s.pixels;
        const double samples = std::max(1.0, 3.0 * double(s.pixels));
        e.maeWith = s.absWith / samples;
        e.maeWithout = s.absWithout / samples;
        e.rmseWith = std::sqrt(s.sqWith / samples);
        e.rmseWithout = std::sqrt(s.sqWithout / samples);
    };
    finish(all, rf.present);
    finish(real, rf.presentReal);
}

/// "all" or a comma list of indices and ranges: "0,5,10-20". Empty set = all.
std::set<std::int64_t> parseFrameList(const std::string& text) {
    std::set<std::int64_t> frames;
    if (text.empty())
        throw Error("--write-frames", std::nullopt,
                    "expected 'all' or indices and ranges like 0,5,10-20, got an empty value");
    if (text == "all") return frames;
    std::stringstream stream(text);
    std::string item;
    while (std::getline(stream, item, ',')) {
        try {
            const auto dash = item.find('-');
            std::size_t used = 0;
            if (dash == std::string::npos) {
                const long long v = std::stoll(item, &used);
                if (used != item.size() || v < 0) throw std::invalid_argument(item);
                frames.insert(v);
            } else {
                const long long a = std::stoll(item.substr(0, dash), &used);
                if (used != dash) throw std::invalid_argument(item);
                const std::string rest = item.substr(dash + 1);
                const long long b = std::stoll(rest, &used);
                if (used != rest.size() || a < 0) throw std::invalid_argument(item);
                if (b < a)
                    throw Error("--write-frames", std::nullopt,
                                "the range '" + item + "' runs backwards; write it as " + std::to_string(b) + "-" +
                                    std::to_string(a));
                if (b - a > 10'000'000) throw std::invalid_argument(item);
                for (long long v = a; v <= b; ++v) frames.insert(v);
            }
        } catch (const Error&) {
            throw;
        } catch (const std::exception&) {
            throw Error("--write-frames", std::nullopt,
                        "expected 'all' or indices and ranges like 0,5,10-20; cannot read '" + item + "'");
        }
    }
    return frames;
}

class Progress {
public:
    Progress(std::optional<std::int64_t> total)
        : total_(total)
        , tty_(stderrIsTerminal())
        , start_(Clock::now()) {}
    void update(std::int64_t done, bool last = false) {
        const double seconds = std::chrono::duration<double>(Clock::now() - start_).count();
        const double fps = seconds > 0 ? double(done) / seconds : 0.0;
        const bool due = std::chrono::duration<double>(Clock::now() - lastPrint_).count() >= (tty_ ? 0.1 : 2.0);
        if ((!due && !last) || !progressWanted()) return;
        lastPrint_ = Clock::now();
        char eta[32] = "?";
        if (total_ && fps > 0) std::snprintf(eta, sizeof eta, "%.0f s", double(*total_ - done) / fps);
        if (tty_) {
            std::string bar;
            if (total_ && *total_ > 0) {
                const int width = 30, filled = int(double(width) * double(done) / double(*total_));
                bar = "[" + std::string(std::size_t(std::min(filled, width)), '#') +
                      std::string(std::size_t(std::max(0, width - filled)), '.') + "] ";
            }
            std::fprintf(stderr, "\r%sframe %lld%s  %.1f fps  ETA %s   ", bar.c_str(), static_cast<long long>(done),
                         total_ ? (" / " + std::to_string(*total_)).c_str() : "", fps, eta);
            if (last) std::fprintf(stderr, "\n");
        } else {
            std::fprintf(stderr, "replay: frame %lld%s, %.1f fps, ETA %s\n", static_cast<long long>(done),
                         total_ ? (" of " + std::to_string(*total_)).c_str() : "", fps, eta);
        }
        std::fflush(stderr);
    }

private:
    using Clock = std::chrono::steady_clock;
    std::optional<std::int64_t> total_;
    bool tty_;
    Clock::time_point start_, lastPrint_{};
};

/// Opens a video writer: MP4 with H.264 (avc1; plays in browsers) when this OpenCV/FFmpeg can
/// write it, else MP4 with MPEG-4 part 2 (mp4v), else MJPG in .avi. On Debian 12's OpenCV 4.6 both
/// MP4 variants work (checked by writing and decoding, also for odd sizes).
cv::VideoWriter openVideo(const std::filesystem::path& folder, const std::string& format, cv::Size size, double fps,
                          std::string& path, std::string& codec) {
    cv::VideoWriter writer;
    if (format != "auto" && format != "mp4" && format != "avi")
        throw Error("--video-format", std::nullopt, "expected auto, mp4 or avi, got '" + format + "'");
    if (format == "auto" || format == "mp4") {
        path = (folder / "replay.mp4").string();
        const std::pair<int, const char*> codecs[] = {
            {cv::VideoWriter::fourcc('a', 'v', 'c', '1'), "H.264 (avc1) in MP4"},
            {cv::VideoWriter::fourcc('m', 'p', '4', 'v'), "MPEG-4 part 2 (mp4v) in MP4"}};
        for (const auto& [fourcc, name] : codecs) {
            if (writer.open(path, cv::CAP_FFMPEG, fourcc, fps, size)) {
                codec = name;
                return writer;
            }
        }
        std::filesystem::remove(path);
        if (format == "mp4") throw Error(path, std::nullopt, "this OpenCV build cannot write MP4 (avc1 or mp4v)");
    }
    path = (folder / "replay.avi").string();
    codec = "MJPG in AVI";
    if (writer.open(path, cv::CAP_ANY, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, size)) {
        if (format == "auto") log::warning("MP4 writing is not available: wrote MJPG " + path);
        return writer;
    }
    throw Error(path, std::nullopt, "OpenCV's VideoWriter can write neither MP4 (avc1, mp4v) nor MJPG AVI here");
}

void writePng(const std::filesystem::path& path, const cv::Mat& image) {
    if (!cv::imwrite(path.string(), image)) throw Error(path.string(), std::nullopt, "could not write the image");
}

/// --linear-out: a linear float image as OpenEXR (32-bit float: NaN, inf and values > 1 survive)
/// when this OpenCV writes EXR (Debian 12's does), else as a golden-format 16-bit PNG + sidecar
/// (eval::writeLinearPng16: clamped to [0, 1], NaN written as 0). Returns the file name used.
std::string writeLinear(const std::filesystem::path& folder, const std::string& stem, const cv::Mat& linear,
                        const std::string& renderer) {
    static const bool exr = cv::haveImageWriter(".exr");
    static const std::vector<int> exrParams{cv::IMWRITE_EXR_TYPE, cv::IMWRITE_EXR_TYPE_FLOAT};
    const std::filesystem::path path = folder / (stem + (exr ? ".exr" : ".png"));
    if (exr) {
        if (!cv::imwrite(path.string(), linear, exrParams))
            throw Error(path.string(), std::nullopt, "could not write the EXR image");
    } else {
        eval::writeLinearPng16(path, linear, renderer);
    }
    return path.filename().string();
}

int runReplay(const ReplayArgs& args) {
    const auto start = std::chrono::steady_clock::now();
    const std::filesystem::path out(args.out);
    // Writes nothing; the folder is made once all inputs are checked (then against the scene's files too).
    checkOutputFolder(out, args.overwrite, "--out", {args.recording, args.scene, args.cacheDir, args.roomModel.load});
    checkRoomModelSave(args.roomModel, out);
    // Scene: --scene, else <recording>/scene.json.
    std::filesystem::path scenePath = args.scene;
    if (scenePath.empty()) {
        scenePath = std::filesystem::path(args.recording) / "scene.json";
        if (!std::filesystem::exists(scenePath))
            throw Error(args.recording, std::nullopt, "no --scene given and the recording has no scene.json");
    }
    const std::set<std::int64_t> chosen = parseFrameList(args.writeFrames);
    render::DebugView view = render::DebugView::Final;
    mr::Overlay overlay = mr::Overlay::None;
    mr::parseView(args.view, view, overlay);

    capture::FrameSourceOptions sourceOptions;
    sourceOptions.softwareRegistration = !args.rawDepth;
    auto opened = capture::openFrameSource(args.recording, sourceOptions);
    if (opened->info().softwareRegistration)
        log::info(args.recording + ": depth is registered to colour in software (" + opened->info().calibrationSource +
                  ")");
    const capture::FrameSourceInfo info = opened->info();
    mr::PoseMode poseMode = args.pose.empty()
                                ? (info.hasGroundTruth ? mr::PoseMode::GroundTruth : mr::PoseMode::Tracking)
                                : mr::parsePoseMode(args.pose);
    // Options that would do nothing with this input are refused with the reason.
    if (poseMode == mr::PoseMode::GroundTruth && !info.hasGroundTruth)
        throw Error("--pose", std::nullopt,
                    "ground-truth: " + args.recording + " has no ground-truth poses (use tracking or fixed)");
    if (args.rawDepth && info.registration == DepthRegistration::RegisteredToColour)
        throw Error("--raw-depth", std::nullopt,
                    "would do nothing: the depth of " + args.recording + " is registered to colour already");

    std::unique_ptr<gl::Context> context;
    std::unique_ptr<gl::WindowContext> window;
    std::optional<WindowDisplay> display; // declared after the window: destroyed first
    if (args.window) {
        window = gl::createWindowContext(info.colourIntrinsics.width, info.colourIntrinsics.height, "lightskin replay");
    } else {
        context = gl::createHeadlessContext();
    }
    const std::string rendererName = window ? window->describe() : context->describe();

    mr::PipelineOptions options;
    options.poseMode = poseMode;
    options.view = view;
    options.overlay = overlay;
    options.compare = !args.noCompare;
    options.adaptive = args.adaptive;
    options.staticTolerance = args.staticTolerance;
    options.linearComposite = true; // the report's NaN/inf counts
    options.linearIndirect = args.linearOut;
    options.differential = args.differential != "off";
    // A synthetic recording rendered with `lightskin synth --objects-present`: compare with that truth.
    const std::filesystem::path presentFolder = std::filesystem::path(args.recording) / "synth" / "present";
    const bool havePresent = std::filesystem::is_directory(presentFolder);
    options.differentialBaseline = havePresent;
    if (args.staticTest != "probes" && args.staticTest != "bound")
        throw Error("--static-test", std::nullopt, "expected probes or bound, got '" + args.staticTest + "'");
    options.staticProbes = args.staticTest == "probes";
    if (!args.backend.empty()) {
        options.backend = gi::parseBackendSetting(args.backend);
        if (!options.backend)
            throw Error("--backend", std::nullopt,
                        "expected " + gi::backendSettingNames(false) + ", got '" + args.backend + "'");
    }
    options.roomModelFile = args.roomModel.load;
    mr::SessionOptions sessionOptions;
    sessionOptions.pipeline = options;
    sessionOptions.budgetMs = args.budgetMs;
    sessionOptions.prefetch = !args.sequential; // same images either way (mr::SessionOptions::prefetch)
    if (!args.cacheDir.empty()) sessionOptions.prtCacheDirectory = std::filesystem::path(args.cacheDir);
    auto session = mr::Session::create(sessionOptions, mr::SceneInput::fromFile(scenePath), std::move(opened));
    capture::FrameSource* source = session->source();
    const render::Scene& scene = session->scene();
    mr::FramePipeline* pipeline = &session->pipeline();
    const std::string sceneTechnique(gi::toString(scene.gi.technique));
    if (!args.cacheDir.empty() && scene.gi.technique != gi::Technique::MultiscalePrt)
        throw Error("--cache-dir", std::nullopt,
                    "would do nothing: " + scenePath.string() + " has gi.technique \"" + sceneTechnique +
                        "\", which has no precompute to cache");
    if (options.backend == gi::BackendSetting::Cpu && !gi::runsOn(scene.gi.technique, gi::Backend::Cpu))
        throw Error("--backend", std::nullopt,
                    "the CPU backend exists for technique lightskin only (" + scenePath.string() +
                        " has gi.technique \"" + sceneTechnique + "\")");
    requireRoomMemoryForSave(args.roomModel, pipeline->hasRoomMemory(), scenePath.string());
    if (source->frameCount() == std::optional<std::int64_t>(0))
        throw Error(args.recording, std::nullopt, "the recording has no frames: nothing to replay");
    // --write-frames past the frames that will be read would silently write nothing.
    if (!chosen.empty()) {
        const std::optional<std::int64_t> available = source->frameCount();
        std::int64_t end = available.value_or(std::numeric_limits<std::int64_t>::max());
        if (args.maxFrames) end = std::min(end, *args.maxFrames);
        if (*chosen.rbegin() >= end)
            throw Error("--write-frames", std::nullopt,
                        "frame " + std::to_string(*chosen.rbegin()) + " will not be read: " +
                            (args.maxFrames && (!available || *args.maxFrames < *available)
                                 ? "--max-frames " + std::to_string(*args.maxFrames) + " stops before it"
                                 : args.recording + " has " + std::to_string(*available) + " frames (0-" +
                                       std::to_string(*available - 1) + ")"));
    }
    InputPaths inputs = sceneInputs(scene);
    inputs.insert(inputs.end(), {args.recording, args.cacheDir, args.roomModel.load});
    prepareOutputFolder(out, args.overwrite, "--out", inputs); // every input is valid: from here on, outputs
    std::filesystem::create_directories(out / "frames");
    // Without a GI technique both halves of the comparison would be the same image.
    const bool compare = options.compare && pipeline->technique() != gi::Technique::None;
    pipeline->options().compare = compare;
    const std::string compareFolder = compareLabels(args.view, pipeline->techniqueName()).folder;
    if (compare) std::filesystem::create_directories(out / compareFolder);
    if (args.linearOut) std::filesystem::create_directories(out / "linear");
    if (args.linearOut && pipeline->technique() != gi::Technique::None)
        std::filesystem::create_directories(out / "linear-indirect");

    std::string videoPath, videoCodec;
    cv::VideoWriter video;
    ReportSummary summary;
    summary.recording = args.recording;
    summary.scene = scenePath.string();
    summary.renderer = rendererName;
    // A frame budget may start on another technique than the scene's.
    const bool asGiven = pipeline->technique() == scene.gi.technique;
    summary.technique =
        pipeline->techniqueName() + (asGiven ? "" : " (scene asked for " + sceneTechnique + ", not available)");
    summary.giBackend = gi::toString(pipeline->backendChoice().backend);
    summary.giBackendReason = gi::toString(pipeline->backendChoice().reason);
    summary.poseMode = mr::toString(poseMode);
    summary.prtPrepare = pipeline->prtPrepareStats();
    summary.command = commandLineText(); // the exact argv: running it again reproduces the run
    summary.framesInSource = source->frameCount();
    std::int64_t total = summary.framesInSource.value_or(-1);
    if (args.maxFrames && (total < 0 || *args.maxFrames < total)) total = *args.maxFrames;

    // The labels, the report's heading and the folder say what the halves show: a shading view
    // compares that view with and without GI; an overlay (VALs, sparse points, ...) is drawn over the
    // composite, beside the composite without GI, and is not "with GI" (the VALs do not depend on it).
    const CompareLabels labels = compareLabels(args.view, pipeline->techniqueName());
    const std::string &withLabel = labels.left, &withoutLabel = labels.right;
    summary.compareLeft = labels.left;
    summary.compareRight = labels.right;
    summary.compareTitle = labels.title;
    const StopSignals stopSignals; // Ctrl-C and SIGTERM: finish this frame, close the video, write the report
    std::vector<ReportFrame> frames;
    Progress progress(total >= 0 ? std::optional<std::int64_t>(total) : std::nullopt);
    cv::Mat sideBySide, presentPair, presentTriple, presentFigure;
    std::int64_t read = 0;
    std::chrono::steady_clock::time_point firstFrameEnd;
    try {
        while (!StopSignals::requested() && (!args.maxFrames || read < *args.maxFrames) && session->processNext()) {
            ++read;
            const mr::FrameOutput& output = session->output();
            const RgbdFrame& frame = session->sourceFrame();
            const mr::FrameReport& report = session->report();
            ReportFrame rf;
            rf.index = report.frameIndex;
            if (report.budgetActive) {
                rf.giSettings = mr::describe(report.settings);
                rf.predictedMs = report.predictedMs;
            }
            rf.trackingState = poseLabel(poseMode, output.tracking);
            rf.trackingReason = output.tracking.reason != nullptr ? output.tracking.reason : "";
            rf.world_T_camera = output.world_T_camera;
            if (output.world_T_camera && frame.groundTruth_world_T_camera) {
                rf.poseErrorMetres =
                    Pose::translationDistance(*output.world_T_camera, *frame.groundTruth_world_T_camera);
                rf.poseErrorDegrees =
                    Pose::rotationAngleBetween(*output.world_T_camera, *frame.groundTruth_world_T_camera) * 180.0 /
                    std::numbers::pi;
            }
            rf.valCount = output.valCount;
            rf.giActive = output.giActive;
            if (!output.giActive) {
                rf.giInactiveCause = output.giInactiveCause;
                if (progressWanted()) // per frame, like the progress; the report keeps every cause
                    std::fprintf(stderr, "replay: frame %lld: GI inactive: %s\n", static_cast<long long>(frame.index),
                                 output.giInactiveCause);
            }
            rf.rsmValCount = output.rsmValCount;
            rf.valsDropped = output.valsDropped;
            rf.cpuTimes = output.cpuTimes;
            rf.gpuTimes = output.gpuTimes;
            rf.totalMs = output.totalMs;
            rf.errorVsBruteForce = output.meanRelativeErrorVsBruteForce;
            rf.vplSegments = output.vplSegments;
            rf.vplNonFinite = output.vplNonFinite;
            rf.giReused = output.giReused;
            rf.giChangeMeasure = output.giChangeMeasure;
            rf.volumeVoxelsDropped = output.volumeVoxelsDropped;
            rf.linearNanPixels = output.linearNanPixels;
            rf.linearInfPixels = output.linearInfPixels;
            rf.lightEstimate = output.lightEstimate;
            rf.roomLightFitted = output.roomLightFitted;
            rf.estimatedLight = output.estimatedLight;
            rf.roomLightCpuMs = output.roomLightCpuMs;
            if (havePresent) {
                char truthName[32];
                std::snprintf(truthName, sizeof truthName, "%06lld.png", static_cast<long long>(frame.index));
                const std::filesystem::path truthPath = presentFolder / truthName;
                const cv::Mat truth = cv::imread(truthPath.string(), cv::IMREAD_COLOR);
                if (truth.empty())
                    throw Error(truthPath.string(), frame.index, "missing or unreadable objects-present image");
                if (truth.size() != frame.colour.size())
                    throw Error(truthPath.string(), frame.index,
                                "objects-present image is not the colour image's size");
                presentErrorInto(truth, frame.colour, output.withGi, output.withGiWithoutDifferential, rf);
                if (chosen.empty() || chosen.count(frame.index) > 0) {
                    // truth | with differential | without (the side-by-side figure)
                    render::sideBySideInto(truth, "objects really there", output.withGi, "with differential",
                                           presentPair);
                    render::sideBySideInto(output.withGiWithoutDifferential, "without differential",
                                           output.withGiWithoutDifferential, "", presentTriple);
                    cv::hconcat(presentPair, presentTriple.colRange(0, output.withGi.cols), presentFigure);
                    std::filesystem::create_directories(out / "present");
                    rf.presentImage = std::string("present/") + truthName;
                    writePng(out / rf.presentImage, presentFigure);
                }
            }
            if (compare) render::sideBySideInto(output.withGi, withLabel, output.withoutGi, withoutLabel, sideBySide);
            const bool write = chosen.empty() || chosen.count(report.frameIndex) > 0;
            if (write) {
                char name[32];
                std::snprintf(name, sizeof name, "%06lld.png", static_cast<long long>(report.frameIndex));
                rf.image = std::string("frames/") + name;
                writePng(out / rf.image, output.withGi);
                if (compare) {
                    rf.compareImage = compareFolder + "/" + name;
                    writePng(out / rf.compareImage, sideBySide);
                }
                if (args.linearOut) {
                    const std::string stem(name, std::strlen(name) - 4); // without ".png"
                    rf.linearImage = "linear/" + writeLinear(out / "linear", stem, output.linearWithGi, rendererName);
                    if (!output.linearIndirect.empty())
                        rf.linearIndirectImage = "linear-indirect/" + writeLinear(out / "linear-indirect", stem,
                                                                                  output.linearIndirect, rendererName);
                }
            }
            if (!args.noVideo) {
                const cv::Mat& videoFrame = args.sideBySideVideo && compare ? sideBySide : output.withGi;
                if (!video.isOpened())
                    video = openVideo(out, args.videoFormat, videoFrame.size(), 30.0, videoPath, videoCodec);
                video.write(videoFrame);
            }
            if (window) {
                if (!display) display.emplace();
                display->show(*window, args.sideBySideVideo && compare ? sideBySide : output.withGi);
                window->swapBuffers();
                window->pollEvents();
                if (window->shouldClose()) StopSignals::request();
            }
            frames.push_back(std::move(rf));
            progress.update(read);
            const auto now = std::chrono::steady_clock::now();
            if (read == 1)
                firstFrameEnd = now;
            else
                summary.steadyMsPerFrame =
                    std::chrono::duration<double, std::milli>(now - firstFrameEnd).count() / double(read - 1);
        }
    } catch (const std::exception& error) {
        // Keep what was written: close the video, write the report marked failed, say what is kept.
        video.release();
        summary.failure = error.what();
        summary.framesRead = read;
        summary.video = videoPath.empty() ? "" : std::filesystem::path(videoPath).filename().string();
        summary.videoCodec = videoCodec;
        summary.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::string kept = "kept in " + out.string() + ": " + std::to_string(frames.size()) + " frames";
        try {
            writeReplayReport(out, summary, frames);
            kept += (summary.video.empty() ? "" : ", " + summary.video) + " and report.md/report.json (marked failed)";
        } catch (const std::exception& reportError) {
            kept += (summary.video.empty() ? "" : ", " + summary.video) + "; the report could not be written (" +
                    reportError.what() + ")";
        }
        throw Error(std::string(error.what()) + "; " + kept);
    }
    progress.update(read, true);
    video.release();
    summary.framesRead = read;
    summary.interrupted = StopSignals::requested();
    summary.video = videoPath.empty() ? "" : std::filesystem::path(videoPath).filename().string();
    summary.videoCodec = videoCodec;
    summary.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    writeReplayReport(out, summary, frames);
    if (!args.roomModel.save.empty()) {
        session->saveRoomModel(args.roomModel.save);
        std::printf("replay: room model saved to %s\n", args.roomModel.save.c_str());
    }
    {
        std::int64_t active = 0;
        for (const ReportFrame& f : frames) active += f.giActive ? 1 : 0;
        if (active == std::int64_t(frames.size()))
            std::printf("replay: GI (%s) active in all %lld frames\n", pipeline->techniqueName().c_str(),
                        static_cast<long long>(active));
        else
            std::printf("replay: GI INACTIVE in %lld of %lld frames (causes per frame in report.md / report.json)\n",
                        static_cast<long long>(std::int64_t(frames.size()) - active),
                        static_cast<long long>(frames.size()));
    }
    std::printf("replay: %lld frames read%s; outputs in %s (report.md, report.json%s)\n", static_cast<long long>(read),
                summary.interrupted ? " (interrupted)" : "", out.string().c_str(),
                videoPath.empty() ? "" : (", " + summary.video).c_str());
    return summary.interrupted ? StopSignals::exitCode() : 0;
}

void addReplayCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand(
        "replay", "Render a scene into a recording: PNGs, a video and a report (headless by default)");
    auto args = std::make_shared<ReplayArgs>();
    command->add_option("recording", args->recording, "Recording folder, TUM folder or .oni file")->required();
    command->add_option("--scene", args->scene, "Scene file (docs/SCENE_FORMAT.md); default <recording>/scene.json");
    command->add_option("--out", args->out, "Output folder: new or empty (see --overwrite)");
    addOverwriteFlag(command, args->overwrite);
    command->add_flag("--window", args->window, "Show a GLFW window while rendering (default: headless EGL)");
    const CLI::Validator frameList(
        [](std::string& text) -> std::string {
            try {
                (void)parseFrameList(text);
            } catch (const Error& error) {
                return error.cause();
            }
            return {};
        },
        "");
    command
        ->add_option("--write-frames", args->writeFrames,
                     "Frames to write as PNG: all, or indices and ranges like 0,5,10-20")
        ->check(frameList);
    command->add_option("--frames", args->writeFrames, "Deprecated spelling of --write-frames")
        ->group("")
        ->check(frameList);
    command->add_option("--max-frames", args->maxFrames, "Stop after this many frames (>= 1; default: all)")
        ->check(atLeast(1));
    command
        ->add_option("--pose", args->pose,
                     "ground-truth | tracking | fixed (default: ground truth when the recording has it, else tracking)")
        ->check(oneOf({"ground-truth", "tracking", "fixed"}));
    command
        ->add_option("--view", args->view,
                     "Debug view: final | direct | indirect | normals | albedo | vals (VALs by flux) | sparse "
                     "(sparse points) | error (vs brute force) | vpl (interpolated vertex VPLs) | differential "
                     "(change of the real light by the virtual objects) | light (the estimated room light: a probe "
                     "ball, the dominant light; needs a light of type estimated)")
        ->check(oneOf({"final", "direct", "indirect", "normals", "albedo", "vals", "sparse", "error", "vpl",
                       "differential", "light"}));
    auto* noVideo = command->add_flag("--no-video", args->noVideo, "Do not write a video");
    command->add_option("--video-format", args->videoFormat, "auto (MP4, falling back to MJPG AVI) | mp4 | avi")
        ->check(CLI::IsMember({"auto", "mp4", "avi"}))
        ->excludes(noVideo);
    auto* sideBySide =
        command->add_flag("--side-by-side-video", args->sideBySideVideo, "Video frames show with GI | without GI")
            ->excludes(noVideo);
    command->add_flag("--no-compare", args->noCompare, "Do not render the without-GI comparison")->excludes(sideBySide);
    command
        ->add_option("--differential", args->differential,
                     "Differential rendering (virtual shadows and bounce on the real surfaces): scene (its "
                     "compositing.differential, default) | off")
        ->check(CLI::IsMember({"scene", "off"}));
    command->add_flag(
        "--linear-out", args->linearOut,
        "Also write each written frame's linear-light composite (linear/) and indirect-only light (linear-indirect/) "
        "as 32-bit float OpenEXR (NaN, inf and values > 1 kept; 16-bit PNG clamped to [0,1] if this OpenCV has no "
        "EXR)");
    command
        ->add_option(
            "--budget-ms", args->budgetMs,
            "Frame-time budget in ms (overrides the scene's gi.budgetMs): per frame pick technique, sparse points, VAL "
            "stride and channels that meet it (docs/PLUGIN.md); report.json lists the choice per frame")
        ->check(finiteIn(0.0, 1e6));
    command
        ->add_option("--backend", args->backend,
                     "LightSkin's stages 0-4 on gl or cpu (SIMD + threads; shading stays on GL), or auto: cpu on a "
                     "software rasterizer (llvmpipe), else gl (default: the scene's gi.backend, whose default is auto)")
        ->check(oneOf(backendSpellings()));
    addRoomModelOptions(command, args->roomModel);
    command->add_flag("--sequential", args->sequential,
                      "Read, depth-filter and track frame n+1 after frame n on one thread (default: on a worker thread "
                      "while frame n renders; the images are the same)");
    command->add_option("--cache-dir", args->cacheDir,
                        "Multi-scale PRT's precompute cache folder (overrides the scene's gi.multiscalePrt cacheDir, "
                        "relative to the working directory; a folder that cannot be written is a warning and the run "
                        "goes on without writing the cache)");
    command->add_flag(
        "--raw-depth", args->rawDepth,
        "Do not register unregistered depth (.oni, fakenect, raw recordings) to colour in software: shows what "
        "the pipeline does without registration (no VALs, no GI)");
    auto* adaptive = command->add_flag(
        "--adaptive", args->adaptive,
        "LightSkin's adaptive mode: turn off what cannot change the image and reuse the VPLs for static content");
    auto* tolerance = command
                          ->add_option("--static-tolerance", args->staticTolerance,
                                       "With --adaptive: also reuse when the gathered irradiance changed by at most "
                                       "this fraction of its maximum (0: exact only; diffuse channel only)")
                          ->check(finiteIn(0.0, 1.0))
                          ->needs(adaptive);
    command
        ->add_option("--static-test", args->staticTest,
                     "With --static-tolerance: probes (re-gather every 16th sparse point) or bound (guaranteed, keyed)")
        ->check(CLI::IsMember({"probes", "bound"}))
        ->needs(tolerance);
    command->callback([args, &exitCode, command] {
        warnIfDeprecatedUsed(*command, "--frames", "--write-frames");
        exitCode = runReplay(*args);
    });
}

} // namespace

static const CommandRegistration registration{"replay", &addReplayCommand};

} // namespace lightskin::apps
