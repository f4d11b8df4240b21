// `lightskin record --source <uri|file> --out <dir>`: records any frame source (live camera,
// .oni, TUM folder, recording) into the lightskin recording format (recordings/README.md), or
// into a fakenect dump with --to-fakenect. Capture never waits for the disk (capture::Recorder);
// frames that cannot be queued or written are counted and reported. Ctrl-C or SIGTERM stops cleanly
// (exit 130 or 143, the recording finished); after a hard kill or a power loss every frame in the
// index is complete, and at most the last --sync-frames / --sync-seconds (plus the queue) are lost
// (capture::RecordingDurability). Exit code 0, or 3 when frames were dropped.
#include "CliSupport.h"
#include "Commands.h"

#include <lightskin/capture/Fakenect.h>
#include <lightskin/capture/FrameSource.h>
#include <lightskin/capture/Recorder.h>
#include <lightskin/capture/Recording.h>
#include <lightskin/core/Error.h>

#include <cstdio>
#include <memory>

namespace lightskin::apps {

namespace {

struct RecordArguments {
    std::string source, out;
    std::optional<std::int64_t> maxFrames; ///< --max-frames; until the end or Ctrl-C when unset
    std::size_t queue = 30;
    capture::RecordingDurability durability;
    bool noFsync = false;
    bool overwrite = false, jpeg = false, realtime = false, toFakenect = false, registerDepth = false;
};

void addRecordCommand(CLI::App& app, int& exitCode) {
    auto* command =
        app.add_subcommand("record", "Record a camera, .oni, TUM folder or recording to a lightskin recording");
    auto args = std::make_shared<RecordArguments>();
    command
        ->add_option("--source", args->source,
                     "openni2://[uri], freenect://<n>, a .oni file, a TUM folder or a recording")
        ->required();
    command->add_option("--out", args->out, "Output folder: new or empty (see --overwrite)")->required();
    addOverwriteFlag(command, args->overwrite);
    command
        ->add_option("--max-frames", args->maxFrames,
                     "Stop after this many frames (>= 1; default: until the end or Ctrl-C)")
        ->check(atLeast(1));
    command->add_option("--frames", args->maxFrames, "Deprecated spelling of --max-frames")
        ->group("")
        ->check(atLeast(1));
    command->add_option("--queue", args->queue, "Frames that may wait for the disk")->check(CLI::Range(1, 10000));
    command
        ->add_option("--sync-frames", args->durability.syncEveryFrames,
                     "Make frames durable and list them in the index every N frames")
        ->check(CLI::Range(std::int64_t{1}, std::int64_t{100000}));
    command
        ->add_option("--sync-seconds", args->durability.syncEverySeconds,
                     "... or when the oldest unlisted frame is this old (seconds)")
        ->check(finiteIn(0.001, 3600.0));
    command->add_flag("--no-fsync", args->noFsync,
                      "Batch the index the same way but never fsync (survives a kill, not a power loss)");
    command->add_flag("--jpeg", args->jpeg, "Store colour as JPEG (lossy, smaller) instead of PNG");
    command->add_flag("--realtime", args->realtime, "Replay recorded sources at their recorded speed");
    command->add_flag("--register-depth", args->registerDepth,
                      "Write depth registered to colour (software registration where the device did not register); "
                      "default: the source's depth as delivered, with its colour_T_depth in the header");
    auto* fakenect = command->add_flag("--to-fakenect", args->toFakenect,
                                       "Write a fakenect dump (640x480) instead of a lightskin recording");
    // A fakenect dump has its own format: the recording's options would do nothing.
    for (const char* option : {"--jpeg", "--queue", "--sync-frames", "--sync-seconds", "--no-fsync"})
        fakenect->excludes(option);
    command->callback([args, &exitCode, command] {
        warnIfDeprecatedUsed(*command, "--frames", "--max-frames");
        const InputPaths inputs{args->source};
        checkOutputFolder(args->out, args->overwrite, "--out", inputs); // before the source opens: nothing written yet
        capture::FrameSourceOptions options;
        options.pacing = args->realtime ? capture::Pacing::Realtime : capture::Pacing::AsFastAsPossible;
        options.softwareRegistration = args->registerDepth;
        auto source = capture::openFrameSource(args->source, options);
        if (args->toFakenect) {
            // The sizes are known from the source's header: refuse before writing anything.
            const capture::FrameSourceInfo& info = source->info();
            for (const auto& [stream, intrinsics] :
                 {std::pair{"colour", &info.colourIntrinsics}, {"depth", &info.depthIntrinsics}})
                if (intrinsics->isValid() && (intrinsics->width != 640 || intrinsics->height != 480))
                    throw Error(args->source, std::nullopt,
                                std::string("--to-fakenect needs 640x480 frames (fakenect's only resolution); the ") +
                                    stream + " images are " + std::to_string(intrinsics->width) + "x" +
                                    std::to_string(intrinsics->height));
        }
        prepareOutputFolder(args->out, args->overwrite, "--out", inputs);
        const StopSignals stopSignals; // Ctrl-C and SIGTERM: finish the recording, then exit 130 / 143
        if (args->toFakenect) {
            const auto frames = capture::writeFakenectDump(*source, args->out, args->maxFrames.value_or(-1));
            std::printf("wrote %lld frames as a fakenect dump to %s\n", static_cast<long long>(frames),
                        args->out.c_str());
            exitCode = StopSignals::exitCode();
            return;
        }
        const auto& info = source->info();
        capture::RecordingInfo recording;
        recording.deviceName = info.deviceName;
        recording.colourIntrinsics = info.colourIntrinsics;
        recording.depthIntrinsics = info.depthIntrinsics;
        recording.depthScaleMetres = info.depthScaleMetres;
        recording.registration = info.registration;
        recording.colour_T_depth = info.colour_T_depth;
        recording.jpegColour = args->jpeg;
        capture::RecordingDurability durability = args->durability;
        durability.fsync = !args->noFsync;
        auto recorder = capture::Recorder::start(capture::RecordingWriter::create(args->out, recording, durability),
                                                 capture::RecorderOptions{args->queue});
        std::printf("recording %s (%s) to %s; Ctrl-C stops\n", args->source.c_str(), info.kind.c_str(),
                    args->out.c_str());
        std::fflush(stdout);
        RgbdFrame frame;
        std::string sourceError;
        try {
            while (!StopSignals::requested() && (!args->maxFrames || source->framesDelivered() < *args->maxFrames) &&
                   source->next(frame))
                recorder->push(frame);
        } catch (const Error& error) {
            sourceError = error.what(); // keep what was recorded: finish the recording first
        }
        const capture::RecorderStats stats = recorder->finish();
        std::printf("recorded %lld frames to %s; dropped %lld (queue full or write failed); source dropped %lld%s\n",
                    static_cast<long long>(stats.written), args->out.c_str(), static_cast<long long>(stats.dropped),
                    static_cast<long long>(source->framesDropped()),
                    StopSignals::requested() ? "; stopped by a signal" : "");
        if (!stats.firstError.empty()) std::printf("first write error: %s\n", stats.firstError.c_str());
        if (!sourceError.empty()) throw Error(sourceError);
        exitCode = StopSignals::requested() ? StopSignals::exitCode() : stats.dropped > 0 ? 3 : 0;
    });
}

} // namespace

static const CommandRegistration registration{"record", &addRecordCommand};

} // namespace lightskin::apps
