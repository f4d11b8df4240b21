#include <lightskin/core/Error.h>
#include <lightskin/core/JsonError.h>
#include <lightskin/synth/SceneDescription.h>

#include <nlohmann/json.hpp>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace lightskin::synth {

namespace {

using Json = nlohmann::json;

// Reads one JSON object strictly: every key must be known (a typo is an error, not a silent
// default), every value of the expected type. Errors name the source and the key path.
class ObjectReader {
public:
    ObjectReader(const Json& object, std::string path, const std::string& source)
        : object_(object), path_(std::move(path)), source_(source) {
        if (!object_.is_object()) fail(path_, "expected an object");
    }
    ObjectReader(const ObjectReader&) = delete;
    ObjectReader& operator=(const ObjectReader&) = delete;

    ~ObjectReader() noexcept(false) {
        if (std::uncaught_exceptions() > 0) return;
        for (const auto& item : object_.items())
            if (!used_.contains(item.key()))
                fail(key(item.key()), "unknown key (see docs/SYNTH.md for the format)");
    }

    bool has(const std::string& name) const { return object_.contains(name); }
    const Json& child(const std::string& name) {
        used_.insert(name);
        return object_.at(name);
    }
    std::string key(const std::string& name) const { return path_.empty() ? name : path_ + "." + name; }

    double number(const std::string& name, double fallback, double min, double max) {
        if (!has(name)) return fallback;
        const Json& value = child(name);
        if (!value.is_number()) fail(key(name), "expected a number");
        const double x = value.get<double>();
        if (!std::isfinite(x) || x < min || x > max)
            fail(key(name), "value " + value.dump() + " outside [" + format(min) + ", " + format(max) + "]");
        return x;
    }
    int integer(const std::string& name, int fallback, int min, int max) {
        if (!has(name)) return fallback;
        const Json& value = child(name);
        if (!value.is_number_integer()) fail(key(name), "expected an integer");
        const auto x = value.get<std::int64_t>();
        if (x < min || x > max)
            fail(key(name), "value " + value.dump() + " outside [" + std::to_string(min) + ", " + std::to_string(max) + "]");
        return int(x);
    }
    std::uint64_t seed(const std::string& name, std::uint64_t fallback) {
        if (!has(name)) return fallback;
        const Json& value = child(name);
        if (!value.is_number_unsigned()) fail(key(name), "expected a non-negative integer");
        return value.get<std::uint64_t>();
    }
    bool boolean(const std::string& name, bool fallback) {
        if (!has(name)) return fallback;
        const Json& value = child(name);
        if (!value.is_boolean()) fail(key(name), "expected true or false");
        return value.get<bool>();
    }
    std::string string(const std::string& name, const std::string& fallback) {
        if (!has(name)) return fallback;
        const Json& value = child(name);
        if (!value.is_string()) fail(key(name), "expected a string");
        return value.get<std::string>();
    }
    glm::dvec3 vec3(const std::string& name, const glm::dvec3& fallback, double min = -1e3, double max = 1e3) {
        if (!has(name)) return fallback;
        const Json& value = child(name);
        if (!value.is_array() || value.size() != 3) fail(key(name), "expected an array of 3 numbers");
        glm::dvec3 result;
        for (int i = 0; i < 3; ++i) {
            const Json& element = value[std::size_t(i)];
            if (!element.is_number()) fail(key(name), "expected an array of 3 numbers");
            result[i] = element.get<double>();
            if (!std::isfinite(result[i]) || result[i] < min || result[i] > max)
                fail(key(name), "component outside [" + format(min) + ", " + format(max) + "]");
        }
        return result;
    }
    /// A colour: [r,g,b] or one number for grey.
    glm::vec3 colour(const std::string& name, const glm::vec3& fallback, double max) {
        if (!has(name)) return fallback;
        if (object_.at(name).is_number()) return glm::vec3(float(number(name, 0.0, 0.0, max)));
        return glm::vec3(vec3(name, glm::dvec3(fallback), 0.0, max));
    }
    glm::dvec2 vec2(const std::string& name, const glm::dvec2& fallback, double min, double max) {
        if (!has(name)) return fallback;
        const Json& value = child(name);
        if (!value.is_array() || value.size() != 2 || !value[0].is_number() || !value[1].is_number())
            fail(key(name), "expected an array of 2 numbers");
        const glm::dvec2 result{value[0].get<double>(), value[1].get<double>()};
        for (int i = 0; i < 2; ++i)
            if (!std::isfinite(result[i]) || result[i] < min || result[i] > max)
                fail(key(name), "component outside [" + format(min) + ", " + format(max) + "]");
        return result;
    }

    [[noreturn]] void fail(const std::string& where, const std::string& cause) const {
        throw Error(source_, std::nullopt, where + ": " + cause);
    }

private:
    static std::string format(double x) {
        std::ostringstream stream;
        stream << x;
        return stream.str();
    }
    const Json& object_;
    std::string path_;
    const std::string& source_;
    std::set<std::string> used_;
};

const Json& arrayChild(ObjectReader& reader, const std::string& name) {
    const Json& value = reader.child(name);
    if (!value.is_array()) reader.fail(reader.key(name), "expected an array");
    return value;
}

Placement readPlacement(ObjectReader& reader, const Placement& fallback = {}) {
    Placement placement;
    placement.position = reader.vec3("position", fallback.position);
    placement.facing = reader.vec3("facing", fallback.facing);
    placement.up = reader.vec3("up", fallback.up);
    const double facingLength = glm::length(placement.facing);
    if (facingLength < 1e-9) reader.fail(reader.key("facing"), "must not be zero");
    const glm::dvec3 facing = placement.facing / facingLength;
    const glm::dvec3 up = placement.up - glm::dot(placement.up, facing) * facing;
    if (glm::length(up) < 1e-6) reader.fail(reader.key("up"), "must not be parallel to facing");
    return placement;
}

PathSegment readSegment(const Json& json, const std::string& path, const std::string& source) {
    ObjectReader reader(json, path, source);
    PathSegment segment;
    const std::string type = reader.string("type", "");
    segment.frames = reader.integer("frames", 1, 1, 100000);
    segment.smooth = reader.boolean("smooth", false);
    if (type == "orbit") {
        segment.type = PathSegmentType::Orbit;
        segment.center = reader.vec3("center", segment.center);
        segment.fromTarget = reader.vec3("target", segment.center);
        segment.radius = reader.number("radius", segment.radius, 0.0, 100.0);
        segment.height = reader.number("height", segment.height, -100.0, 100.0);
        segment.startDegrees = reader.number("startDegrees", segment.startDegrees, -3600.0, 3600.0);
        segment.endDegrees = reader.number("endDegrees", segment.endDegrees, -3600.0, 3600.0);
    } else if (type == "linear") {
        ObjectReader from(reader.child("from"), reader.key("from"), source);
        segment.fromPosition = from.vec3("position", segment.fromPosition);
        segment.fromTarget = from.vec3("target", segment.fromTarget);
        ObjectReader to(reader.child("to"), reader.key("to"), source);
        segment.toPosition = to.vec3("position", segment.toPosition);
        segment.toTarget = to.vec3("target", segment.toTarget);
    } else if (type == "pan") {
        segment.type = PathSegmentType::Pan;
        segment.fromPosition = reader.vec3("position", segment.fromPosition);
        segment.startDegrees = reader.number("startDegrees", segment.startDegrees, -3600.0, 3600.0);
        segment.endDegrees = reader.number("endDegrees", segment.endDegrees, -3600.0, 3600.0);
        segment.pitchDegrees = reader.number("pitchDegrees", 0.0, -89.0, 89.0);
    } else if (type == "hold") {
        segment.type = PathSegmentType::Hold;
        segment.fromPosition = reader.vec3("position", segment.fromPosition);
        segment.fromTarget = reader.vec3("target", segment.fromTarget);
    } else {
        reader.fail(reader.key("type"), "expected \"orbit\", \"linear\", \"pan\" or \"hold\", got \"" + type + "\"");
    }
    if (type == "linear") segment.type = PathSegmentType::Linear;
    return segment;
}

} // namespace

Pose Placement::world_T_face() const {
    const glm::dvec3 z = glm::normalize(facing);
    const glm::dvec3 y = glm::normalize(up - glm::dot(up, z) * z);
    const glm::dvec3 x = glm::cross(y, z);
    const glm::dmat3 rotation(x, y, z);
    return Pose(glm::quat_cast(rotation), position);
}

std::vector<TagDescription> TagBoardDescription::expand() const {
    std::vector<TagDescription> tags;
    const Pose world_T_board = placement.world_T_face();
    for (int row = 0; row < rows; ++row) {
        for (int column = 0; column < columns; ++column) {
            TagDescription tag;
            tag.family = family;
            tag.id = firstId + row * columns + column;
            tag.sizeMetres = sizeMetres;
            // Board frame: x right, y up as seen from the front; row 0 is the top row.
            const glm::dvec3 offset{(column - (columns - 1) * 0.5) * spacingMetres,
                                    ((rows - 1) * 0.5 - row) * spacingMetres, 0.0};
            tag.placement = placement;
            tag.placement.position = world_T_board.transformPoint(offset);
            tags.push_back(tag);
        }
    }
    return tags;
}

int CameraPathDescription::frameCount() const noexcept {
    int count = 0;
    for (const PathSegment& segment : segments) count += segment.frames;
    return count;
}

void SceneDescription::validate() const {
    const std::string source = sourcePath.empty() ? name : sourcePath.string();
    if (!intrinsics.isValid() || intrinsics.width > 4096 || intrinsics.height > 4096)
        throw Error(source, std::nullopt, "camera: invalid intrinsics " + intrinsics.describe());
    if (path.segments.empty()) throw Error(source, std::nullopt, "path.segments: at least one segment is needed");
    if (path.frameCount() > 100000) throw Error(source, std::nullopt, "path: more than 100000 frames");
    if (!(nearMetres > 0.0 && farMetres > nearMetres)) throw Error(source, std::nullopt, "camera: need 0 < near < far");
    if (lights.size() > 8) throw Error(source, std::nullopt, "lights: at most 8 lights");
    int lightSamples = 0;
    for (const LightDescription& light : lights) lightSamples += light.type == LightType::Area ? light.samples * light.samples : 1;
    if (lightSamples > 256)
        throw Error(source, std::nullopt, "lights: " + std::to_string(lightSamples) + " light samples, at most 256 in total");
    if (boxes.size() > 32) throw Error(source, std::nullopt, "boxes: at most 32 boxes");
    if (tags.size() > 64) throw Error(source, std::nullopt, "tags: at most 64 tags (boards included)");
    std::set<std::pair<std::string, int>> ids;
    for (const TagDescription& tag : tags)
        if (!ids.insert({tag.family, tag.id}).second)
            throw Error(source, std::nullopt, "tags: " + tag.family + " id " + std::to_string(tag.id) + " appears twice");
    if (noise.minRangeMetres >= noise.maxRangeMetres) throw Error(source, std::nullopt, "noise: need minRange < maxRange");
    if (noise.grazingStartDegrees > noise.grazingEndDegrees)
        throw Error(source, std::nullopt, "noise: need grazingStartDegrees <= grazingEndDegrees");
    if (depthScaleMetres * 65535.0 < farMetres && depthScaleMetres * 65535.0 < glm::length(room.size))
        throw Error(source, std::nullopt, "depth.scaleMetres: the room does not fit into 16 bits at this scale");
}

SceneDescription parseSceneDescription(const std::string& jsonText, const std::string& sourceName) {
    Json json;
    try {
        json = Json::parse(jsonText);
    } catch (const Json::exception& error) { // parse_error, and out_of_range for a number that overflows
        throw Error(sourceName, std::nullopt, "not valid JSON: " + jsonErrorCause(error.what()));
    }
    SceneDescription scene;
    {
        ObjectReader top(json, "", sourceName);
        if (top.string("format", "") != "lightskin-synth-scene")
            top.fail("format", "expected \"lightskin-synth-scene\"");
        if (top.integer("version", 0, 0, 1000) != 1) top.fail("version", "only version 1 is supported");
        scene.name = top.string("name", "scene");

        if (top.has("room")) {
            ObjectReader room(top.child("room"), "room", sourceName);
            scene.room.size = room.vec3("size", scene.room.size, 0.5, 100.0);
            scene.room.floorAlbedo = room.colour("floor", scene.room.floorAlbedo, 1.0);
            scene.room.ceilingAlbedo = room.colour("ceiling", scene.room.ceilingAlbedo, 1.0);
            scene.room.westAlbedo = room.colour("west", scene.room.westAlbedo, 1.0);
            scene.room.eastAlbedo = room.colour("east", scene.room.eastAlbedo, 1.0);
            scene.room.southAlbedo = room.colour("south", scene.room.southAlbedo, 1.0);
            scene.room.northAlbedo = room.colour("north", scene.room.northAlbedo, 1.0);
        }
        if (top.has("boxes")) {
            const Json& boxes = arrayChild(top, "boxes");
            for (std::size_t i = 0; i < boxes.size(); ++i) {
                ObjectReader reader(boxes[i], "boxes[" + std::to_string(i) + "]", sourceName);
                BoxDescription box;
                box.name = reader.string("name", "box" + std::to_string(i));
                box.center = reader.vec3("center", box.center);
                box.size = reader.vec3("size", box.size, 1e-3, 100.0);
                box.yawDegrees = reader.number("yawDegrees", 0.0, -360.0, 360.0);
                box.albedo = reader.colour("albedo", box.albedo, 1.0);
                scene.boxes.push_back(box);
            }
        }
        if (top.has("lights")) {
            const Json& lights = arrayChild(top, "lights");
            for (std::size_t i = 0; i < lights.size(); ++i) {
                ObjectReader reader(lights[i], "lights[" + std::to_string(i) + "]", sourceName);
                LightDescription light;
                const std::string type = reader.string("type", "");
                if (type == "point") {
                    light.type = LightType::Point;
                    light.placement.position = reader.vec3("position", light.placement.position);
                } else if (type == "area") {
                    light.type = LightType::Area;
                    light.placement = readPlacement(reader, Placement{{0.0, 0.0, 0.0}, {0.0, 0.0, -1.0}, {0.0, 1.0, 0.0}});
                    light.size = reader.vec2("size", light.size, 1e-3, 100.0);
                    light.samples = reader.integer("samples", light.samples, 1, 8);
                } else {
                    reader.fail(reader.key("type"), "expected \"point\" or \"area\"");
                }
                light.powerWatts = reader.colour("powerWatts", light.powerWatts, 1e5);
                scene.lights.push_back(light);
            }
        }
        scene.ambientRadiance = top.colour("ambientRadiance", scene.ambientRadiance, 1e4);
        if (top.has("tags")) {
            const Json& tags = arrayChild(top, "tags");
            for (std::size_t i = 0; i < tags.size(); ++i) {
                ObjectReader reader(tags[i], "tags[" + std::to_string(i) + "]", sourceName);
                TagDescription tag;
                tag.family = reader.string("family", tag.family);
                tag.id = reader.integer("id", 0, 0, 1 << 20);
                tag.sizeMetres = reader.number("size", tag.sizeMetres, 1e-3, 10.0);
                tag.placement = readPlacement(reader);
                scene.tags.push_back(tag);
            }
        }
        if (top.has("tagBoards")) {
            const Json& boards = arrayChild(top, "tagBoards");
            for (std::size_t i = 0; i < boards.size(); ++i) {
                ObjectReader reader(boards[i], "tagBoards[" + std::to_string(i) + "]", sourceName);
                TagBoardDescription board;
                board.family = reader.string("family", board.family);
                board.firstId = reader.integer("firstId", 0, 0, 1 << 20);
                board.rows = reader.integer("rows", board.rows, 1, 8);
                board.columns = reader.integer("columns", board.columns, 1, 8);
                board.sizeMetres = reader.number("size", board.sizeMetres, 1e-3, 10.0);
                board.spacingMetres = reader.number("spacing", board.spacingMetres, 1e-3, 10.0);
                if (board.spacingMetres < board.sizeMetres) reader.fail(reader.key("spacing"), "must be at least size");
                board.placement = readPlacement(reader);
                for (const TagDescription& tag : board.expand()) scene.tags.push_back(tag);
            }
        }
        if (top.has("tagAlbedo")) {
            ObjectReader reader(top.child("tagAlbedo"), "tagAlbedo", sourceName);
            scene.tagBlackAlbedo = float(reader.number("black", scene.tagBlackAlbedo, 0.0, 1.0));
            scene.tagWhiteAlbedo = float(reader.number("white", scene.tagWhiteAlbedo, 0.0, 1.0));
        }
        if (top.has("camera")) {
            ObjectReader reader(top.child("camera"), "camera", sourceName);
            const std::string preset = reader.string("preset", "kinect-v1");
            if (preset != "kinect-v1") reader.fail("camera.preset", "only \"kinect-v1\" (525/525/319.5/239.5 at 640x480) is known");
            const int width = reader.integer("width", 320, 16, 4096);
            const int height = reader.integer("height", 240, 16, 4096);
            CameraIntrinsics intrinsics = CameraIntrinsics::kinectV1Default().scaledTo(width, height);
            intrinsics.fx = reader.number("fx", intrinsics.fx, 1.0, 1e5);
            intrinsics.fy = reader.number("fy", intrinsics.fy, 1.0, 1e5);
            intrinsics.cx = reader.number("cx", intrinsics.cx, -1e4, 1e4);
            intrinsics.cy = reader.number("cy", intrinsics.cy, -1e4, 1e4);
            scene.intrinsics = intrinsics;
            scene.nearMetres = reader.number("near", scene.nearMetres, 1e-3, 10.0);
            scene.farMetres = reader.number("far", scene.farMetres, 0.1, 1000.0);
        }
        if (top.has("path")) {
            ObjectReader reader(top.child("path"), "path", sourceName);
            scene.path.fps = reader.number("fps", scene.path.fps, 0.1, 1000.0);
            if (reader.has("segments")) {
                const Json& segments = arrayChild(reader, "segments");
                for (std::size_t i = 0; i < segments.size(); ++i)
                    scene.path.segments.push_back(readSegment(segments[i], "path.segments[" + std::to_string(i) + "]", sourceName));
            }
            if (reader.has("shake")) {
                ObjectReader shake(reader.child("shake"), "path.shake", sourceName);
                scene.path.shake.translationStdMetres = shake.number("translationStdMetres", 0.0, 0.0, 1.0);
                scene.path.shake.rotationStdDegrees = shake.number("rotationStdDegrees", 0.0, 0.0, 30.0);
                scene.path.shake.seed = shake.seed("seed", 1);
            }
        }
        if (top.has("render")) {
            ObjectReader reader(top.child("render"), "render", sourceName);
            scene.exposure = reader.number("exposure", scene.exposure, 1e-6, 1e6);
            scene.supersampling = reader.integer("supersampling", scene.supersampling, 1, 8);
        }
        if (top.has("depth")) {
            ObjectReader reader(top.child("depth"), "depth", sourceName);
            scene.depthScaleMetres = reader.number("scaleMetres", scene.depthScaleMetres, 1e-5, 0.01);
        }
        if (top.has("noise")) {
            ObjectReader reader(top.child("noise"), "noise", sourceName);
            DepthNoiseDescription& noise = scene.noise;
            noise.enabled = reader.boolean("enabled", true);
            noise.seed = reader.seed("seed", noise.seed);
            noise.minRangeMetres = reader.number("minRangeMetres", noise.minRangeMetres, 0.0, 100.0);
            noise.maxRangeMetres = reader.number("maxRangeMetres", noise.maxRangeMetres, 0.0, 100.0);
            noise.baselineMetres = reader.number("baselineMetres", noise.baselineMetres, -1.0, 1.0);
            noise.sensorFocalPixels = reader.number("sensorFocalPixels", noise.sensorFocalPixels, 1.0, 1e5);
            noise.disparitySubpixel = reader.number("disparitySubpixel", noise.disparitySubpixel, 0.0, 1024.0);
            noise.axialNoise = reader.boolean("axialNoise", noise.axialNoise);
            noise.lateralNoise = reader.boolean("lateralNoise", noise.lateralNoise);
            noise.projectorShadow = reader.boolean("projectorShadow", noise.projectorShadow);
            noise.grazingStartDegrees = reader.number("grazingStartDegrees", noise.grazingStartDegrees, 0.0, 90.0);
            noise.grazingEndDegrees = reader.number("grazingEndDegrees", noise.grazingEndDegrees, 0.0, 90.0);
            noise.edgeDropoutProbability = reader.number("edgeDropoutProbability", noise.edgeDropoutProbability, 0.0, 1.0);
            noise.edgeJumpRelative = reader.number("edgeJumpRelative", noise.edgeJumpRelative, 1e-4, 10.0);
        }
        if (top.has("outputs")) {
            ObjectReader reader(top.child("outputs"), "outputs", sourceName);
            scene.writeNormals = reader.boolean("normals", false);
            scene.writePositions = reader.boolean("positions", false);
            scene.writeRadiance = reader.boolean("radiance", false);
        }
    }
    scene.sourcePath = sourceName;
    scene.validate();
    return scene;
}

SceneDescription loadSceneDescription(const std::filesystem::path& path) {
    std::ifstream file(path, std::ios::binary);
    if (!file) throw Error(path.string(), std::nullopt, "cannot open the scene description");
    file.seekg(0, std::ios::end);
    const std::streamoff size = file.tellg();
    if (size < 0 || size > (std::streamoff(16) << 20)) throw Error(path.string(), std::nullopt, "scene description larger than 16 MiB");
    file.seekg(0);
    std::string text(std::size_t(size), '\0');
    file.read(text.data(), size);
    if (!file) throw Error(path.string(), std::nullopt, "could not read the scene description");
    return parseSceneDescription(text, path.string());
}

} // namespace lightskin::synth
