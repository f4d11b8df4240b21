// `lightskin live`: the AR demo. Frames from a device (freenect://0, openni2://...) or a file
// (.oni, recording, TUM folder: replayed at the recorded speed), the scene composited with GI,
// shown in a GLFW window with an on-screen line (frame rate, stage times, switches).
//
// Keys: G GI on/off, L glossy on/off, O occlusion on/off, V next debug view, C with/without-GI
// comparison side by side, P snapshot (PNG in --snapshot-dir), Q or Esc quit.
// --headless runs the same loop without a window (EGL), for tests and machines without a display.
// Ctrl-C or SIGTERM stops after the current frame and finishes the --record recording (exit 130 or 143).
#include "CliSupport.h"
#include "Commands.h"
#include "ImageOutput.h"
#include "LiveWindowDisplay.h"
#include "PoseLabel.h"
#include "RoomModelOptions.h"
#include "SceneInputs.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/capture/Recording.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/gl/Context.h>
#include <lightskin/gl/DebugOutput.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/mr/LiveFrameReader.h>
#include <lightskin/mr/Session.h>
#include <lightskin/render/Scene.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>

namespace lightskin::apps {

namespace {

// GLFW key codes (printable keys are their upper-case ASCII codes; GLFW_KEY_ESCAPE = 256).
constexpr int kKeyEscape = 256;

struct LiveArgs {
    std::string device = "freenect://0", scene, pose, snapshot, snapshotDir = ".", record;
    RoomModelOptions roomModel; ///< --room-model, --save-room-model
    bool headless = false, loop = false, fast = false, overwrite = false;
    std::optional<std::int64_t> maxFrames, snapshotAfter; ///< unset: all frames / no automatic snapshot
    double budgetMs = 0.0;                                ///< --budget-ms (0: the scene's gi.budgetMs, if any)
};

std::string statusLine(double fps, const mr::FrameOutput& out, const mr::FramePipeline& pipeline,
                       const mr::PipelineOptions& options) {
    std::string line;
    char text[64];
    std::snprintf(text, sizeof text, "%.1f fps |", fps);
    line += text;
    for (const auto& st : out.cpuTimes) {
        std::snprintf(text, sizeof text, " %s %.1f", st.name.c_str(), st.milliseconds);
        line += text;
    }
    line += " ms | GI ";
    // Glossy and occlusion are channels of a GI technique: without one they do nothing, so say nothing.
    const bool gi = options.giEnabled && pipeline.technique() != lightskin::gi::Technique::None;
    line += options.giEnabled ? pipeline.techniqueName() : std::string("off");
    line += gi && pipeline.giSettings().glossy ? " +glossy" : "";
    line += gi && pipeline.giSettings().occlusion ? " +occl" : "";
    line += options.differential && out.differentialReceivers >= 0 ? " | differential" : "";
    if (!out.giActive && out.giInactiveCause != nullptr) line += std::string(" INACTIVE: ") + out.giInactiveCause;
    line += " | ";
    const char* overlays[] = {
        "", " + vals", " + sparse points", " + error vs brute force", " + vertex VPLs", " + differential"};
    line += render::toString(options.view);
    line += overlays[int(options.overlay)];
    line += " | ";
    line += poseLabel(options.poseMode, out.tracking);
    return line;
}

void drawStatus(cv::Mat& image, const std::string& line) {
    const double scale = std::max(0.35, double(image.cols) / 1600.0);
    const cv::Point origin(6, image.rows - 8);
    cv::putText(image, line, origin, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
    cv::putText(image, line, origin, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
}

void writePng(const std::filesystem::path& path, const cv::Mat& image) {
    if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
    if (!cv::imwrite(path.string(), image)) throw Error(path.string(), std::nullopt, "could not write the snapshot");
    std::printf("live: wrote %s\n", path.string().c_str());
}

int runLive(const LiveArgs& args) {
    if (args.scene.empty()) throw Error("--scene", std::nullopt, "live needs a scene file (docs/SCENE_FORMAT.md)");
    if (!args.record.empty())
        checkOutputFolder(args.record, args.overwrite, "--record", {args.device, args.scene, args.roomModel.load});
    checkRoomModelSave(args.roomModel, args.record);
    // Where snapshots go is checked before the camera and GL start (a file there fails at once).
    const std::filesystem::path firstSnapshot = args.snapshot.empty()
                                                    ? std::filesystem::path(args.snapshotDir) / "snapshot-0.png"
                                                    : std::filesystem::path(args.snapshot);
    checkImageOutput(firstSnapshot, {args.device, args.scene}, args.snapshot.empty() ? "--snapshot-dir" : "--snapshot");
    if (!args.snapshot.empty())
        checkImageOutput(std::filesystem::path(args.snapshotDir) / "snapshot-0.png", {}, "--snapshot-dir");
    const std::string uri = args.device == "freenect" ? "freenect://0" : args.device;
    capture::FrameSourceOptions sourceOptions;
    sourceOptions.pacing = args.fast ? capture::Pacing::AsFastAsPossible : capture::Pacing::Realtime;
    sourceOptions.loop = args.loop;
    auto source = capture::openFrameSource(uri, sourceOptions);
    const capture::FrameSourceInfo& info = source->info();
    if (args.snapshotAfter) {
        // A snapshot after more frames than will be shown would silently never be written.
        const std::optional<std::int64_t> count = args.loop ? std::nullopt : source->frameCount();
        if (args.maxFrames && *args.snapshotAfter >= *args.maxFrames)
            throw Error("--snapshot-after", std::nullopt,
                        std::to_string(*args.snapshotAfter) + " frames: --max-frames " +
                            std::to_string(*args.maxFrames) + " stops before (at most " +
                            std::to_string(*args.maxFrames - 1) + ")");
        if (count && *args.snapshotAfter >= *count)
            throw Error("--snapshot-after", std::nullopt,
                        std::to_string(*args.snapshotAfter) + " frames: " + uri + " has " + std::to_string(*count) +
                            " frames (at most " + std::to_string(*count - 1) + ", or add --loop)");
    }

    std::unique_ptr<gl::Context> headless;
    std::unique_ptr<gl::WindowContext> window;
    if (args.headless) {
        headless = gl::createHeadlessContext();
    } else {
        window = gl::createWindowContext(info.colourIntrinsics.width, info.colourIntrinsics.height, "lightskin live");
    }
    mr::PipelineOptions options;
    options.poseMode = args.pose.empty() ? (info.hasGroundTruth ? mr::PoseMode::GroundTruth : mr::PoseMode::Tracking)
                                         : mr::parsePoseMode(args.pose);
    options.compare = false;
    options.roomModelFile = args.roomModel.load;
    mr::SessionOptions sessionOptions;
    sessionOptions.pipeline = options;
    sessionOptions.budgetMs = args.budgetMs;
    // The session runs the frames this command reads (it also records them).
    auto session = mr::Session::create(sessionOptions, mr::SceneInput::fromFile(args.scene), info);
    mr::FramePipeline* pipeline = &session->pipeline();
    requireRoomMemoryForSave(args.roomModel, pipeline->hasRoomMemory(), args.scene);
    std::printf("live: %s (%s), scene %s, pose %s, GI %s\n", info.uri.c_str(), info.kind.c_str(), args.scene.c_str(),
                mr::toString(options.poseMode), pipeline->techniqueName().c_str());
    if (window)
        std::printf("keys: G GI, L glossy, O occlusion, D differential, V debug view, C side by side, P snapshot, "
                    "Q/Esc quit\n");

    std::optional<capture::RecordingWriter> recorder;
    if (!args.record.empty()) {
        capture::RecordingInfo recordingInfo;
        recordingInfo.deviceName = info.deviceName;
        recordingInfo.colourIntrinsics = info.colourIntrinsics;
        recordingInfo.depthIntrinsics = info.depthIntrinsics;
        recordingInfo.depthScaleMetres = info.depthScaleMetres;
        recordingInfo.registration = info.registration;
        recordingInfo.colour_T_depth = info.colour_T_depth;
        InputPaths inputs = sceneInputs(session->scene());
        inputs.insert(inputs.end(), {args.device, args.roomModel.load});
        prepareOutputFolder(args.record, args.overwrite, "--record", inputs);
        recorder = capture::RecordingWriter::create(args.record, recordingInfo);
    }

    bool snapshotRequested = false, quit = false;
    int snapshots = 0;
    if (window) {
        window->setKeyHandler([&](int key) {
            mr::PipelineOptions& o = pipeline->options();
            render::GiSettings gi = pipeline->giSettings();
            switch (key) {
            case 'G':
                o.giEnabled = !o.giEnabled;
                break;
            case 'L':
                gi.glossy = !gi.glossy;
                pipeline->setGiSettings(gi);
                break;
            case 'O':
                gi.occlusion = !gi.occlusion;
                pipeline->setGiSettings(gi);
                break;
            case 'V':
                // final, direct, indirect, normals, albedo, then the overlays vals, sparse, error, vpl, differential.
                if (o.overlay != mr::Overlay::None) {
                    o.overlay = mr::Overlay((int(o.overlay) + 1) % mr::kOverlayCount);
                } else if (o.view == render::DebugView::Albedo) {
                    o.view = render::DebugView::Final;
                    o.overlay = mr::Overlay::Vals;
                } else {
                    o.view = render::DebugView(int(o.view) + 1);
                }
                break;
            case 'C':
                o.compare = !o.compare;
                break;
            case 'D':
                o.differential = !o.differential;
                break;
            case 'P':
                snapshotRequested = true;
                break;
            case 'Q':
            case kKeyEscape:
                quit = true;
                break;
            default:
                break;
            }
        });
    }

    const StopSignals stopSignals;
    WindowDisplay display;
    mr::LiveFrameReader reader(*source);
    RgbdFrame frame;
    cv::Mat shown, clean; // clean: what is shown without the status line (snapshots)
    std::int64_t count = 0;
    double fps = 0.0;
    auto last = std::chrono::steady_clock::now();
    try {
        while (!quit && !StopSignals::requested() && (!args.maxFrames || count < *args.maxFrames)) {
            const mr::LiveFrameReader::Result result = reader.next(frame);
            if (result == mr::LiveFrameReader::Result::Ended) break;
            if (result == mr::LiveFrameReader::Result::Stalled) {
                // The camera paused: keep the last image up with the stall on its status line and
                // the window responsive, and wait for frames again (the reader gives up eventually).
                if (window) {
                    if (!shown.empty()) {
                        drawStatus(shown, reader.status());
                        display.show(*window, shown);
                    }
                    window->swapBuffers();
                    window->pollEvents();
                    if (window->shouldClose()) quit = true;
                } else {
                    std::fprintf(stderr, "live: %s\n", reader.status().c_str());
                }
                continue;
            }
            ++count;
            if (recorder) recorder->write(frame);
            session->process(frame);
            const mr::FrameOutput& out = session->output();
            if (pipeline->options().compare)
                render::sideBySideInto(out.withGi, "with GI", out.withoutGi, "without GI", shown);
            else
                out.withGi.copyTo(shown);
            const auto now = std::chrono::steady_clock::now();
            const double seconds = std::chrono::duration<double>(now - last).count();
            last = now;
            fps = fps == 0.0 ? 1.0 / std::max(seconds, 1e-6) : 0.9 * fps + 0.1 / std::max(seconds, 1e-6);
            const bool autoSnapshot = args.snapshotAfter && count == *args.snapshotAfter + 1;
            // Snapshots are the rendered image, without the status line (which a 640-pixel frame cuts off).
            if (autoSnapshot || snapshotRequested) shown.copyTo(clean);
            drawStatus(shown, reader.status().empty()
                                  ? statusLine(fps, out, *pipeline, pipeline->options())
                                  : statusLine(fps, out, *pipeline, pipeline->options()) + " | " + reader.status());
            if (window) {
                display.show(*window, shown);
                if (autoSnapshot || snapshotRequested) {
                    const std::filesystem::path path = autoSnapshot && !args.snapshot.empty()
                                                           ? std::filesystem::path(args.snapshot)
                                                           : std::filesystem::path(args.snapshotDir) /
                                                                 ("snapshot-" + std::to_string(snapshots++) + ".png");
                    writePng(path, clean);
                }
                window->swapBuffers();
                window->pollEvents();
                if (window->shouldClose()) quit = true;
            } else {
                if (autoSnapshot)
                    writePng(args.snapshot.empty() ? std::filesystem::path(args.snapshotDir) / "snapshot-0.png"
                                                   : std::filesystem::path(args.snapshot),
                             clean);
                if (count % 30 == 1 && progressWanted())
                    std::fprintf(stderr, "live: frame %lld: %s\n", static_cast<long long>(count),
                                 statusLine(fps, out, *pipeline, pipeline->options()).c_str());
            }
            snapshotRequested = false;
            gl::DebugOutput::throwIfErrors("live frame");
        }
    } catch (...) {
        try {
            if (recorder) recorder->finish(); // keep what was recorded
        } catch (const std::exception&) {
            // the first failure is the one to report
        }
        throw;
    }
    if (recorder) recorder->finish();
    if (!args.roomModel.save.empty()) {
        session->saveRoomModel(args.roomModel.save);
        std::printf("live: room model saved to %s\n", args.roomModel.save.c_str());
    }
    std::printf("live: %lld frames, %lld dropped by the source, %lld camera stalls survived\n",
                static_cast<long long>(count), static_cast<long long>(source->framesDropped()),
                static_cast<long long>(reader.stalls()));
    return StopSignals::exitCode();
}

void addLiveCommand(CLI::App& app, int& exitCode) {
    auto* command =
        app.add_subcommand("live", "AR demo in a window: camera or file input, scene lit with GI, keys to toggle");
    auto args = std::make_shared<LiveArgs>();
    command->add_option(
        "--device", args->device,
        "freenect (Kinect v1), freenect://<n>, openni2://[uri], a .oni file, a recording or TUM folder");
    command->add_option("--scene", args->scene, "Scene file (docs/SCENE_FORMAT.md)")->required();
    command
        ->add_option("--pose", args->pose,
                     "ground-truth | tracking | fixed (default: ground truth when the input has it, else tracking)")
        ->check(oneOf({"ground-truth", "tracking", "fixed"}));
    command->add_flag("--headless", args->headless, "No window: render through EGL (tests, no display)");
    command->add_flag("--loop", args->loop, "Start file input again at its end");
    command->add_flag("--fast", args->fast, "File input as fast as possible instead of at the recorded speed");
    command->add_option("--max-frames", args->maxFrames, "Stop after this many frames (>= 1; default: all)")
        ->check(atLeast(1));
    auto* after = command
                      ->add_option("--snapshot-after", args->snapshotAfter,
                                   "Write a snapshot of what is shown (without the status line) after this many frames")
                      ->check(atLeast(0));
    command->add_option("--snapshot", args->snapshot, "Path of that snapshot (default <snapshot-dir>/snapshot-0.png)")
        ->needs(after);
    command->add_option("--snapshot-dir", args->snapshotDir, "Folder for snapshots (key P)");
    addRoomModelOptions(command, args->roomModel);
    command
        ->add_option("--budget-ms", args->budgetMs,
                     "Frame-time budget in ms: the session picks the GI settings per frame (docs/PLUGIN.md)")
        ->check(finiteIn(0.0, 1e6));
    command->add_option("--record", args->record,
                        "Also record the input frames into this recording folder: new or empty (see --overwrite)");
    addOverwriteFlag(command, args->overwrite);
    command->callback([args, &exitCode] { exitCode = runLive(*args); });
}

} // namespace

static const CommandRegistration registration{"live", &addLiveCommand};

} // namespace lightskin::apps
