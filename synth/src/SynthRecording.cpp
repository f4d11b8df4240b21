#include <lightskin/capture/Recording.h>
#include <lightskin/core/Error.h>
#include <lightskin/synth/Generator.h>
#include <lightskin/synth/SynthRecording.h>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>

namespace lightskin::synth {

namespace {

using Json = nlohmann::json;

Json poseJson(const Pose& pose) {
    const glm::dquat& q = pose.rotation();
    const glm::dvec3& t = pose.translation();
    return {{"translation", {t.x, t.y, t.z}}, {"quaternionXyzw", {q.x, q.y, q.z, q.w}}};
}

void writeText(const std::filesystem::path& path, const std::string& text) {
    std::ofstream file(path, std::ios::binary);
    file << text;
    file.close();
    if (!file) throw Error(path.string(), std::nullopt, "could not write the file");
}

void writeChannel(const std::filesystem::path& folder, const char* channel, std::int64_t index, const cv::Mat& image) {
    char name[32];
    std::snprintf(name, sizeof name, "%06lld.tiff", static_cast<long long>(index));
    const std::filesystem::path path = folder / "synth" / channel / name;
    // Deflate: lossless (OpenCV's default for float TIFF is not, in 4.6).
    const std::vector<int> parameters{cv::IMWRITE_TIFF_COMPRESSION, 8};
    bool written = false;
    try {
        written = cv::imwrite(path.string(), image, parameters);
    } catch (const cv::Exception& error) {
        throw Error(path.string(), index, std::string("could not write the channel image: ") + error.what());
    }
    if (!written) throw Error(path.string(), index, "could not write the channel image");
}

} // namespace

std::int64_t writeSynthRecording(const SceneDescription& scene, const std::string& sceneText,
                                 const std::filesystem::path& folder, const SynthRecordingOptions& options,
                                 const TagBitmapSource& tags) {
    Generator generator = Generator::create(scene, tags);
    // Every input is read before the first file is written: a bad objects scene leaves no half recording.
    std::optional<PresentObjects> present;
    if (!options.presentObjects.empty())
        present = PresentObjects::create(scene, loadPresentObjects(options.presentObjects), tags);
    capture::RecordingInfo info;
    info.deviceName = "lightskin synth: " + scene.name;
    info.colourIntrinsics = info.depthIntrinsics = scene.intrinsics;
    info.depthScaleMetres = scene.depthScaleMetres;
    info.registration = DepthRegistration::RegisteredToColour;
    capture::RecordingWriter writer = capture::RecordingWriter::create(folder, info);

    std::error_code error;
    std::filesystem::create_directories(folder / "synth", error);
    for (const char* channel : {"normals", "positions", "radiance"}) {
        const bool wanted = (channel[0] == 'n' && scene.writeNormals) || (channel[0] == 'p' && scene.writePositions) ||
                            (channel[0] == 'r' && scene.writeRadiance);
        if (wanted) std::filesystem::create_directories(folder / "synth" / channel, error);
    }
    if (error)
        throw Error((folder / "synth").string(), std::nullopt, "could not create the folder: " + error.message());
    writeText(folder / "synth" / "scene.json", sceneText);
    if (present) {
        std::filesystem::create_directories(folder / "synth" / "present", error);
        if (error)
            throw Error((folder / "synth" / "present").string(), std::nullopt,
                        "could not create the folder: " + error.message());
    }

    Json tagList = Json::array();
    for (const TagDescription& tag : scene.tags) {
        Json corners = Json::array();
        for (const glm::dvec3& corner : SceneRenderer::tagCornersWorld(tag))
            corners.push_back({corner.x, corner.y, corner.z});
        tagList.push_back({{"family", tag.family},
                           {"id", tag.id},
                           {"sizeMetres", tag.sizeMetres},
                           {"world_T_tag", poseJson(tag.placement.world_T_face())},
                           {"cornersWorld", corners}});
    }
    Json groundTruth = {
        {"format", "lightskin-synth-ground-truth"},
        {"version", 1},
        {"scene", scene.name},
        {"exposure", scene.exposure},
        {"colour", "sRGB(clamp(exposure * radiance)), radiance in W m^-2 sr^-1, direct light only"},
        {"depthScaleMetres", scene.depthScaleMetres},
        {"depthNoise", scene.noise.enabled},
        {"tagFrame", "x right, y up, z out of the tag surface; corners top-left, top-right, bottom-right, bottom-left"},
        {"tags", tagList}};
    if (present)
        groundTruth["present"] = {
            {"objects", options.presentObjects.filename().string()},
            {"folder", "synth/present"},
            {"model", "objects really in the room: exact light visibility, one bounce (synth/PresentObjects.h)"}};
    writeText(folder / "synth" / "ground-truth.json", groundTruth.dump(2) + "\n");

    // The same tags as a tracking world (tracking/TagWorld.h), so replay can track against the
    // scene's own world frame. One family per world file: written when all tags share one.
    if (!scene.tags.empty() && std::all_of(scene.tags.begin(), scene.tags.end(),
                                           [&](const TagDescription& t) { return t.family == scene.tags[0].family; })) {
        Json worldTags = Json::array();
        for (const TagDescription& tag : scene.tags) {
            const Pose world_T_tag = tag.placement.world_T_face();
            const glm::dquat& q = world_T_tag.rotation();
            const glm::dvec3& t = world_T_tag.translation();
            worldTags.push_back({{"id", tag.id},
                                 {"size", tag.sizeMetres},
                                 {"position", {t.x, t.y, t.z}},
                                 {"orientation", {q.w, q.x, q.y, q.z}}});
        }
        writeText(folder / "synth" / "tag-world.json",
                  Json{{"family", scene.tags[0].family}, {"tags", worldTags}}.dump(2) + "\n");
    }

    const int total =
        options.maxFrames > 0 ? std::min(options.maxFrames, generator.frameCount()) : generator.frameCount();
    SynthFrame frame;
    cv::Mat presentRadiance, presentColour;
    for (int index = 0; index < total && !(options.stopRequested && options.stopRequested()); ++index) {
        generator.renderFrameInto(index, frame);
        writer.write(frame.frame);
        if (scene.writeNormals) writeChannel(folder, "normals", index, frame.exact.worldNormal);
        if (scene.writePositions) writeChannel(folder, "positions", index, frame.exact.worldPosition);
        if (scene.writeRadiance) writeChannel(folder, "radiance", index, frame.exact.radiance);
        if (present) {
            present->renderInto(*frame.frame.groundTruth_world_T_camera, frame.exact, presentRadiance);
            presentColour.create(presentRadiance.size(), CV_8UC3);
            for (int v = 0; v < presentRadiance.rows; ++v)
                for (int u = 0; u < presentRadiance.cols; ++u)
                    for (int c = 0; c < 3; ++c)
                        presentColour.at<cv::Vec3b>(v, u)[c] =
                            encodeSrgb(float(scene.exposure) * presentRadiance.at<cv::Vec3f>(v, u)[c]);
            char name[32];
            std::snprintf(name, sizeof name, "%06d.png", index);
            const std::filesystem::path path = folder / "synth" / "present" / name;
            if (!cv::imwrite(path.string(), presentColour))
                throw Error(path.string(), index, "could not write the present-objects image");
        }
        if (options.progress) options.progress(index + 1, total);
    }
    writer.finish();
    return writer.framesWritten();
}

cv::Mat readSynthChannel(const std::filesystem::path& file) {
    cv::Mat image;
    try {
        image = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
    } catch (const cv::Exception& error) {
        throw Error(file.string(), std::nullopt, std::string("could not read the channel image: ") + error.what());
    }
    if (image.empty()) throw Error(file.string(), std::nullopt, "missing or unreadable channel image");
    if (image.type() != CV_32FC3) throw Error(file.string(), std::nullopt, "expected a 3-channel float image");
    return image;
}

} // namespace lightskin::synth
