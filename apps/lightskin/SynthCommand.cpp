// `lightskin synth <scene.json> --out <folder>`: renders a synthetic RGB-D recording with exact
// ground truth (poses, depth, optional normals/positions/radiance) from a scene description
// (docs/SYNTH.md). Headless: OpenGL 4.5 through EGL, no GPU needed. Ctrl-C or SIGTERM stops after the
// current frame with a finished recording of the frames written (exit 130 or 143).
#include "CliSupport.h"
#include "Commands.h"
#include "ToolCommands.h"

#include <lightskin/capture/Fakenect.h>
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/gl/Context.h>
#include <lightskin/synth/PresentObjects.h>
#include <lightskin/synth/SynthRecording.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <unistd.h>

namespace lightskin::apps {

namespace {

struct SynthArguments {
    std::string scene;
    std::string out;
    int maxFrames = 0; ///< --max-frames (>= 1); 0: the whole path
    bool overwrite = false, noNoise = false;
    std::optional<std::uint64_t> noiseSeed;
    std::string fakenect;
    std::string objectsPresent;
};

void addSynthCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand("synth", toolDescription("synth"));
    auto arguments = std::make_shared<SynthArguments>();
    command->add_option("scene", arguments->scene, "Scene description (JSON, docs/SYNTH.md)")->required();
    command->add_option("--out", arguments->out, "Folder to write the recording to: new or empty (see --overwrite)")
        ->required();
    addOverwriteFlag(command, arguments->overwrite);
    command
        ->add_option("--max-frames", arguments->maxFrames, "Write at most this many frames (>= 1; 0: the whole path)")
        ->check(atLeast(1));
    command->add_option("--frames", arguments->maxFrames, "Deprecated spelling of --max-frames")
        ->group("")
        ->check(atLeast(1));
    command->add_flag("--no-noise", arguments->noNoise, "Exact depth: switch the depth noise model off");
    command->add_option("--noise-seed", arguments->noiseSeed, "Override the noise seed")
        ->check(CLI::Range(std::uint64_t{0}, std::numeric_limits<std::uint64_t>::max()));
    command->add_option(
        "--objects-present", arguments->objectsPresent,
        "A lightskin scene file: also render every frame with its virtual objects really in the room into "
        "synth/present/ (the ground truth of the differential composite; docs/SYNTH.md)");
    command->add_option(
        "--fakenect", arguments->fakenect,
        "Also write the recording as a fakenect dump into this folder (needs 640x480; capture/Fakenect.h; "
        "new or empty, see --overwrite)");
    command->callback([arguments, &exitCode, command] {
        warnIfDeprecatedUsed(*command, "--frames", "--max-frames");
        const InputPaths inputs{arguments->scene, arguments->objectsPresent};
        checkOutputFolder(arguments->out, arguments->overwrite, "--out", inputs);
        if (!arguments->fakenect.empty()) {
            checkOutputFolder(arguments->fakenect, arguments->overwrite, "--fakenect", inputs);
            checkNotAnInput(arguments->fakenect, {arguments->out}, "--fakenect");
        }
        std::ifstream file(arguments->scene, std::ios::binary);
        if (!file) throw Error(arguments->scene, std::nullopt, "cannot open the scene description");
        std::ostringstream text;
        text << file.rdbuf();
        synth::SceneDescription scene = synth::parseSceneDescription(text.str(), arguments->scene);
        if (arguments->noNoise) scene.noise.enabled = false;
        if (arguments->noiseSeed) scene.noise.seed = *arguments->noiseSeed;
        if (!arguments->fakenect.empty() && (scene.intrinsics.width != 640 || scene.intrinsics.height != 480))
            throw Error(arguments->scene, std::nullopt,
                        "--fakenect needs a 640x480 camera (fakenect's only resolution)");

        // Read before anything is written (the recording reads it again once the folder is made).
        if (!arguments->objectsPresent.empty()) (void)synth::loadPresentObjects(arguments->objectsPresent);

        auto context = gl::createHeadlessContext();
        synth::SynthRecordingOptions options;
        options.maxFrames = arguments->maxFrames;
        options.presentObjects = arguments->objectsPresent;
        // Progress about once a second (every 5 s into a file or pipe) with the time left.
        const bool tty = stderrIsTerminal();
        const auto started = std::chrono::steady_clock::now();
        auto lastPrint = started - std::chrono::hours(1);
        options.progress = [tty, started, lastPrint](int written, int total) mutable {
            const auto now = std::chrono::steady_clock::now();
            if (!progressWanted() || (written != total && now - lastPrint < std::chrono::seconds(tty ? 1 : 5))) return;
            lastPrint = now;
            const double seconds = std::chrono::duration<double>(now - started).count();
            const double left = written > 0 ? seconds / written * (total - written) : 0.0;
            std::fprintf(stderr, "%ssynth: frame %d of %d, %.1f s, ETA %.0f s%s", tty ? "\r" : "", written, total,
                         seconds, left, tty && written != total ? "   " : "\n");
        };
        options.stopRequested = [] { return StopSignals::requested(); };
        prepareOutputFolder(arguments->out, arguments->overwrite, "--out", inputs);
        const StopSignals stopSignals; // Ctrl-C and SIGTERM: finish the recording with the frames written
        if (!arguments->fakenect.empty())
            prepareOutputFolder(arguments->fakenect, arguments->overwrite, "--fakenect", inputs);
        const std::int64_t frames = synth::writeSynthRecording(scene, text.str(), arguments->out, options);
        std::printf("wrote %lld frames of %s (%s) to %s\n", static_cast<long long>(frames), scene.name.c_str(),
                    scene.intrinsics.describe().c_str(), arguments->out.c_str());
        if (!arguments->fakenect.empty() && !StopSignals::requested()) {
            auto source = capture::openFrameSource(arguments->out);
            const std::int64_t dumped = capture::writeFakenectDump(*source, arguments->fakenect);
            std::printf("wrote %lld frames as a fakenect dump to %s\n", static_cast<long long>(dumped),
                        arguments->fakenect.c_str());
        }
        exitCode = StopSignals::exitCode();
    });
}

} // namespace

static const CommandRegistration registration{"synth", &addSynthCommand};

} // namespace lightskin::apps
