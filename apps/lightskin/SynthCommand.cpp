// `lightskin synth <scene.json> --out <folder>`: renders a synthetic RGB-D recording with exact
// ground truth (poses, depth, optional normals/positions/radiance) from a scene description
// (docs/SYNTH.md). Headless: OpenGL 4.5 through EGL, no GPU needed.
#include "Commands.h"

#include <lightskin/capture/Fakenect.h>
#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/gl/Context.h>
#include <lightskin/synth/SynthRecording.h>

#include <cstdio>
#include <fstream>
#include <sstream>

namespace lightskin::apps {

namespace {

struct SynthArguments {
    std::string scene;
    std::string out;
    int maxFrames = 0;
    bool noNoise = false;
    std::optional<std::uint64_t> noiseSeed;
    std::string fakenect;
    std::string objectsPresent;
};

void addSynthCommand(CLI::App& app, int& exitCode) {
    auto* command = app.add_subcommand("synth", "Render a synthetic RGB-D recording with exact ground truth from a scene description");
    auto arguments = std::make_shared<SynthArguments>();
    command->add_option("scene", arguments->scene, "Scene description (JSON, docs/SYNTH.md)")->required();
    command->add_option("--out", arguments->out, "Folder to write the recording to (must not exist or be empty)")->required();
    command->add_option("--frames", arguments->maxFrames, "Write at most this many frames (default: the whole path)");
    command->add_flag("--no-noise", arguments->noNoise, "Exact depth: switch the depth noise model off");
    command->add_option("--noise-seed", arguments->noiseSeed, "Override the noise seed");
    command->add_option(
        "--objects-present", arguments->objectsPresent,
        "A lightskin scene file: also render every frame with its virtual objects really in the room into "
        "synth/present/ (the ground truth of the differential composite; docs/SYNTH.md)");
    command->add_option("--fakenect", arguments->fakenect,
                        "Also write the recording as a fakenect dump into this folder (needs 640x480; capture/Fakenect.h)");
    command->callback([arguments, &exitCode] {
        std::ifstream file(arguments->scene, std::ios::binary);
        if (!file) throw Error(arguments->scene, std::nullopt, "cannot open the scene description");
        std::ostringstream text;
        text << file.rdbuf();
        synth::SceneDescription scene = synth::parseSceneDescription(text.str(), arguments->scene);
        if (arguments->noNoise) scene.noise.enabled = false;
        if (arguments->noiseSeed) scene.noise.seed = *arguments->noiseSeed;

        auto context = gl::createHeadlessContext();
        synth::SynthRecordingOptions options;
        options.maxFrames = arguments->maxFrames;
        options.presentObjects = arguments->objectsPresent;
        options.progress = [](int written, int total) {
            if (written == total || written % 10 == 0) std::fprintf(stderr, "\rframe %d/%d", written, total);
            if (written == total) std::fprintf(stderr, "\n");
        };
        const std::int64_t frames = synth::writeSynthRecording(scene, text.str(), arguments->out, options);
        std::printf("wrote %lld frames of %s (%s) to %s\n", static_cast<long long>(frames), scene.name.c_str(),
                    scene.intrinsics.describe().c_str(), arguments->out.c_str());
        if (!arguments->fakenect.empty()) {
            if (scene.intrinsics.width != 640 || scene.intrinsics.height != 480)
                throw Error(arguments->scene, std::nullopt, "--fakenect needs a 640x480 camera (fakenect's only resolution)");
            auto source = capture::openFrameSource(arguments->out);
            const std::int64_t dumped = capture::writeFakenectDump(*source, arguments->fakenect);
            std::printf("wrote %lld frames as a fakenect dump to %s\n", static_cast<long long>(dumped), arguments->fakenect.c_str());
        }
        exitCode = 0;
    });
}

} // namespace

static const CommandRegistration registration{"synth", &addSynthCommand};

} // namespace lightskin::apps
