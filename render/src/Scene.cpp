#include <lightskin/core/Error.h>
#include <lightskin/core/JsonError.h>
#include <lightskin/core/JsonReader.h>
#include <lightskin/render/Scene.h>
#include <lightskin/render/Skinning.h>

#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>

namespace lightskin::render {

namespace {

using nlohmann::json;

MaterialOverride readMaterial(const JsonReader& r, const json& value, const std::string& p) {
    r.object(value, p);
    r.allowOnly(value, p, {"diffuseAlbedo", "specularAlbedo", "specularExponent", "diffuseTexture"});
    MaterialOverride m;
    if (value.contains("diffuseAlbedo")) m.diffuseAlbedo = r.colour(value["diffuseAlbedo"], p + "/diffuseAlbedo", 1.0f, "in [0, 1]");
    if (value.contains("specularAlbedo")) m.specularAlbedo = r.colour(value["specularAlbedo"], p + "/specularAlbedo", 1.0f, "in [0, 1]");
    if (value.contains("specularExponent"))
        m.specularExponent = r.number(value["specularExponent"], p + "/specularExponent", 1.0f, 1e6f, ">= 1 (Phong exponent k)");
    if (value.contains("diffuseTexture")) m.diffuseTexture = r.existingFile(value["diffuseTexture"], p + "/diffuseTexture", "texture");
    return m;
}

constexpr std::size_t kMaxAnimationKeys = 100000;

const json& readKeyArray(const JsonReader& r, const json& animation, const std::string& p) {
    if (!animation.contains("keys")) r.fail(p + "/keys", "an array of at least one key", nullptr);
    const json& keys = animation["keys"];
    if (!keys.is_array() || keys.empty() || keys.size() > kMaxAnimationKeys)
        r.fail(p + "/keys", "an array of 1 to " + std::to_string(kMaxAnimationKeys) + " keys", &keys);
    return keys;
}

/// A key's "t": seconds >= 0 after the previous key's (`previous` < 0 for the first key).
double readKeyTime(const JsonReader& r, const json& key, const std::string& k, double previous) {
    if (!key.contains("t")) r.fail(k + "/t", "the key's time in seconds from the first frame", nullptr);
    const double t = r.number(key["t"], k + "/t", 0.0f, 1e7f, ">= 0 (seconds from the first frame)");
    if (previous >= 0.0 && !(t > previous))
        r.fail(k + "/t",
               "a time after the previous key's (" + std::to_string(previous) + " s): keys in increasing time",
               &key["t"]);
    return t;
}

void checkLoop(const JsonReader& r, bool loop, std::size_t keyCount, const std::string& p) {
    if (loop && keyCount < 2) r.fail(p + "/loop", "at least two keys to loop over", nullptr);
}

glm::mat4 readTransform(const JsonReader& r, const json& value, const std::string& p) {
    r.object(value, p);
    r.allowOnly(value, p, {"translation", "rotationDegrees", "scale", "matrix"});
    if (value.contains("matrix")) {
        if (value.size() != 1) r.fail(p, "either \"matrix\" alone or translation/rotationDegrees/scale", nullptr);
        const json& m = value["matrix"];
        if (!m.is_array() || m.size() != 16) r.fail(p + "/matrix", "16 numbers (row-major 4x4, last row 0 0 0 1)", &m);
        glm::mat4 out;
        for (int row = 0; row < 4; ++row)
            for (int col = 0; col < 4; ++col)
                out[col][row] = r.number(m[std::size_t(row * 4 + col)], p + "/matrix/" + std::to_string(row * 4 + col), -1e6f, 1e6f, "(finite)");
        if (out[0][3] != 0.0f || out[1][3] != 0.0f || out[2][3] != 0.0f || out[3][3] != 1.0f)
            r.fail(p + "/matrix", "a last row of 0 0 0 1 (an affine transform)", &m);
        return out;
    }
    glm::vec3 t(0.0f), rot(0.0f);
    float s = 1.0f;
    if (value.contains("translation")) t = r.vec3(value["translation"], p + "/translation", -1e4f, 1e4f, "(metres)");
    if (value.contains("rotationDegrees")) rot = r.vec3(value["rotationDegrees"], p + "/rotationDegrees", -1e4f, 1e4f, "(degrees)");
    if (value.contains("scale")) s = r.number(value["scale"], p + "/scale", 1e-6f, 1e6f, "> 0 (uniform scale)");
    return composeTransform(t, rot, s);
}

bool isGltfAnimation(const json& value) { return value == "gltf" || (value.is_object() && value.contains("source")); }

/// The object's "animation": "gltf" or {"source": "gltf", "clip": name or index, "loop": bool}: a clip of the
/// mesh file, inside the object's placement; rigid (node) motion, or the deformation of a skinned mesh.
void readGltfAnimation(const JsonReader& r, const json& value, const std::string& p, SceneObject& object) {
    GltfObjectAnimation animation;
    animation.world_T_file = object.world_T_model;
    ClipChoice choice;
    if (value.is_object()) {
        r.allowOnly(value, p, {"source", "clip", "loop"});
        if (value["source"] != "gltf")
            r.fail(p + "/source", "\"gltf\" (the mesh file's own animation)", &value["source"]);
        if (value.contains("loop")) animation.loop = r.boolean(value["loop"], p + "/loop");
        if (value.contains("clip")) {
            const json& clip = value["clip"];
            if (clip.is_string())
                choice.clip = clip.get<std::string>();
            else if (clip.is_number_unsigned())
                choice.clip = clip.get<std::size_t>();
            else
                r.fail(p + "/clip", "a clip's name or its index (integer >= 0) in the mesh file", &clip);
        }
    }
    try {
        if (hasSkin(object.mesh)) {
            checkSkinnedClip(object.mesh, choice);
            object.skinAnimation = GltfSkinAnimation{.clip = choice, .loop = animation.loop};
            return;
        }
        animation.rigid = loadRigidClip(object.mesh, choice);
    } catch (const Error& error) {
        r.fail(p, "an animation the mesh file can play (" + error.source() + ": " + error.cause() + ")", &value);
    }
    object.gltfAnimation = std::move(animation);
    object.world_T_model = sampleGltfAnimation(*object.gltfAnimation, 0.0);
}

/// The object's "animation": {"keys": [{"t", "translation", "rotationDegrees", "scale"}, ...], "loop"}.
TransformAnimation readTransformAnimation(const JsonReader& r, const json& value, const std::string& p) {
    if (!value.is_object())
        r.fail(p,
               "an object {\"keys\": [{\"t\": seconds, \"translation\", \"rotationDegrees\", \"scale\"}, ...], "
               "\"loop\": bool}, or \"gltf\" (the mesh file's animation)",
               &value);
    r.allowOnly(value, p, {"keys", "loop"});
    TransformAnimation animation;
    if (value.contains("loop")) animation.loop = r.boolean(value["loop"], p + "/loop");
    const json& keys = readKeyArray(r, value, p);
    for (std::size_t i = 0; i < keys.size(); ++i) {
        const std::string k = p + "/keys/" + std::to_string(i);
        r.object(keys[i], k);
        r.allowOnly(keys[i], k, {"t", "translation", "rotationDegrees", "scale"});
        TransformKey key;
        key.timeSeconds = readKeyTime(r, keys[i], k, i == 0 ? -1.0 : animation.keys.back().timeSeconds);
        if (keys[i].contains("translation"))
            key.translation = r.vec3(keys[i]["translation"], k + "/translation", -1e4f, 1e4f, "(metres)");
        if (keys[i].contains("rotationDegrees"))
            key.rotation = rotationFromEulerDegrees(
                r.vec3(keys[i]["rotationDegrees"], k + "/rotationDegrees", -1e4f, 1e4f, "(degrees)"));
        if (keys[i].contains("scale"))
            key.scale = r.number(keys[i]["scale"], k + "/scale", 1e-6f, 1e6f, "> 0 (uniform scale)");
        animation.keys.push_back(key);
    }
    checkLoop(r, animation.loop, animation.keys.size(), p);
    return animation;
}

/// A light's "animation": keys of position, direction (spot lights) and power; a key's missing values are the light's.
LightAnimation readLightAnimation(const JsonReader& r, const json& value, const std::string& p,
                                  const SceneLight& light) {
    r.object(value, p);
    r.allowOnly(value, p, {"keys", "loop"});
    LightAnimation animation;
    if (value.contains("loop")) animation.loop = r.boolean(value["loop"], p + "/loop");
    const json& keys = readKeyArray(r, value, p);
    for (std::size_t i = 0; i < keys.size(); ++i) {
        const std::string k = p + "/keys/" + std::to_string(i);
        r.object(keys[i], k);
        r.allowOnly(keys[i], k, {"t", "position", "direction", "power"});
        LightKey key{.timeSeconds = readKeyTime(r, keys[i], k, i == 0 ? -1.0 : animation.keys.back().timeSeconds),
                     .position = light.position,
                     .direction = light.direction,
                     .power = light.power};
        if (keys[i].contains("position"))
            key.position = r.vec3(keys[i]["position"], k + "/position", -1e4f, 1e4f, "(metres)");
        if (keys[i].contains("power")) key.power = r.colour(keys[i]["power"], k + "/power", 1e6f, ">= 0 (watts)");
        if (keys[i].contains("direction")) {
            if (light.type != LightType::Spot)
                r.fail(k + "/direction", "no direction on a point light (only spot lights have one)", nullptr);
            const glm::vec3 d = r.vec3(keys[i]["direction"], k + "/direction", -1e4f, 1e4f, "(direction)");
            if (glm::length(d) < 1e-6f) r.fail(k + "/direction", "a non-zero direction", &keys[i]["direction"]);
            key.direction = glm::normalize(d);
        }
        animation.keys.push_back(key);
    }
    checkLoop(r, animation.loop, animation.keys.size(), p);
    return animation;
}

SceneObject readObject(const JsonReader& r, const json& value, const std::string& p, std::size_t index) {
    r.object(value, p);
    r.allowOnly(value, p, {"name", "mesh", "transform", "material", "animation", "visible"});
    SceneObject o;
    o.name = value.contains("name") ? r.string(value["name"], p + "/name") : "object" + std::to_string(index);
    if (!value.contains("mesh")) r.fail(p + "/mesh", "a mesh file path (OBJ, PLY or glTF; relative to the scene file)", nullptr);
    o.mesh = r.existingFile(value["mesh"], p + "/mesh", "mesh file");
    if (value.contains("transform")) o.world_T_model = readTransform(r, value["transform"], p + "/transform");
    if (value.contains("material")) o.material = readMaterial(r, value["material"], p + "/material");
    if (value.contains("animation") && isGltfAnimation(value["animation"])) {
        readGltfAnimation(r, value["animation"], p + "/animation", o);
    } else if (value.contains("animation")) {
        if (value.contains("transform"))
            r.fail(p + "/animation", "either \"transform\" or \"animation\" (whose keys place the object), not both",
                   nullptr);
        o.animation = readTransformAnimation(r, value["animation"], p + "/animation");
        o.world_T_model = sampleTransform(*o.animation, 0.0);
    }
    if (value.contains("visible")) o.visible = r.boolean(value["visible"], p + "/visible");
    return o;
}

/// {"type": "estimated", "shadows", "stride", "fitInterval", "timeConstantSeconds", "referenceAlbedo",
/// "distantLightMetres"}: the room's
/// own light, whose position and power the pipeline sets every frame (no power or position in the file).
SceneLight readEstimatedLight(const JsonReader& r, const json& value, const std::string& p) {
    r.allowOnly(
        value, p,
        {"type", "shadows", "stride", "fitInterval", "timeConstantSeconds", "referenceAlbedo", "distantLightMetres"});
    SceneLight l;
    l.type = LightType::Estimated;
    l.power = glm::vec3(0.0f); // dark until the first estimate
    l.inRoom = true;           // a real room light: its light is in the camera image already
    EstimatedLightSettings& e = l.estimation;
    if (value.contains("shadows")) l.castsShadows = r.boolean(value["shadows"], p + "/shadows");
    if (value.contains("stride")) e.stride = r.integer(value["stride"], p + "/stride", 1, 64);
    if (value.contains("fitInterval")) e.fitInterval = r.integer(value["fitInterval"], p + "/fitInterval", 1, 300);
    if (value.contains("timeConstantSeconds"))
        e.timeConstantSeconds = r.number(value["timeConstantSeconds"], p + "/timeConstantSeconds", 0.0f, 3600.0f,
                                         "in [0, 3600] (seconds; 0 = no temporal filter)");
    if (value.contains("referenceAlbedo"))
        e.referenceAlbedo =
            r.number(value["referenceAlbedo"], p + "/referenceAlbedo", 0.01f, 1.0f, "in [0.01, 1] (an albedo)");
    if (value.contains("distantLightMetres"))
        e.distantLightMetres =
            r.number(value["distantLightMetres"], p + "/distantLightMetres", 0.5f, 15.0f, "in [0.5, 15] (metres)");
    return l;
}

SceneLight readLight(const JsonReader& r, const json& value, const std::string& p) {
    r.object(value, p);
    if (value.contains("type") && value["type"].is_string() && value["type"].get<std::string>() == "estimated")
        return readEstimatedLight(r, value, p);
    r.allowOnly(value, p,
                {"type", "position", "direction", "power", "coneAngleDegrees", "coneFalloffDegrees", "shadows",
                 "inRoom", "animation"});
    SceneLight l;
    const std::string type = value.contains("type") ? r.string(value["type"], p + "/type") : "";
    if (type == "point") l.type = LightType::Point;
    else if (type == "spot") l.type = LightType::Spot;
    else
        r.fail(p + "/type", "\"point\", \"spot\" or \"estimated\"", value.contains("type") ? &value["type"] : nullptr);
    if (!value.contains("position")) r.fail(p + "/position", "[x, y, z] in metres (world frame)", nullptr);
    l.position = r.vec3(value["position"], p + "/position", -1e4f, 1e4f, "(metres)");
    if (value.contains("power")) l.power = r.colour(value["power"], p + "/power", 1e6f, ">= 0 (watts)");
    if (l.type == LightType::Spot) {
        if (!value.contains("direction")) r.fail(p + "/direction", "a direction [x, y, z] for a spot light", nullptr);
        const glm::vec3 d = r.vec3(value["direction"], p + "/direction", -1e4f, 1e4f, "(direction)");
        if (glm::length(d) < 1e-6f) r.fail(p + "/direction", "a non-zero direction", &value["direction"]);
        l.direction = glm::normalize(d);
        if (value.contains("coneAngleDegrees"))
            l.coneAngleDegrees = r.number(value["coneAngleDegrees"], p + "/coneAngleDegrees", 0.1f, 89.0f, "in [0.1, 89] degrees");
        if (value.contains("coneFalloffDegrees"))
            l.coneFalloffDegrees = r.number(value["coneFalloffDegrees"], p + "/coneFalloffDegrees", 0.0f, 45.0f, "in [0, 45] degrees");
    } else {
        for (const char* key : {"direction", "coneAngleDegrees", "coneFalloffDegrees"})
            if (value.contains(key)) r.fail(p + "/" + key, "no such key on a point light (only spot lights have it)", nullptr);
    }
    if (value.contains("shadows")) l.castsShadows = r.boolean(value["shadows"], p + "/shadows");
    if (value.contains("inRoom")) l.inRoom = r.boolean(value["inRoom"], p + "/inRoom");
    if (value.contains("animation")) {
        l.animation = readLightAnimation(r, value["animation"], p + "/animation", l);
        const LightKey start = sampleLight(*l.animation, 0.0); // as an animated object starts at its first key
        l.position = start.position;
        l.direction = start.direction;
        l.power = start.power;
    }
    return l;
}

} // namespace

bool isAnimated(const SceneObject& object) { return object.animation || object.gltfAnimation || object.skinAnimation; }

glm::mat4 placementAt(const SceneObject& object, double timeSeconds) {
    if (object.animation) return sampleTransform(*object.animation, timeSeconds);
    if (object.gltfAnimation) return sampleGltfAnimation(*object.gltfAnimation, timeSeconds);
    return object.world_T_model;
}

glm::mat4 composeTransform(const glm::vec3& translation, const glm::vec3& rotationDegrees, float scale) {
    glm::mat4 m = glm::translate(glm::mat4(1.0f), translation);
    m = glm::rotate(m, glm::radians(rotationDegrees.z), glm::vec3(0, 0, 1));
    m = glm::rotate(m, glm::radians(rotationDegrees.y), glm::vec3(0, 1, 0));
    m = glm::rotate(m, glm::radians(rotationDegrees.x), glm::vec3(1, 0, 0));
    return glm::scale(m, glm::vec3(scale));
}

Scene parseScene(std::string_view text, const std::filesystem::path& baseFolder, const std::string& sourceName) {
    json root;
    try {
        root = json::parse(text.begin(), text.end());
    } catch (const json::exception& error) { // parse_error, and out_of_range for a number that overflows
        throw Error(sourceName, std::nullopt, "not valid JSON: " + jsonErrorCause(error.what()));
    }
    const JsonReader r(sourceName, baseFolder);
    r.object(root, "");
    r.allowOnly(
        root, "",
        {"version", "objects", "lights", "gi", "tracking", "roomModel", "exposureStops", "compositing", "description"});
    if (!root.contains("version") || !root["version"].is_number_integer() || root["version"].get<std::int64_t>() != 1)
        r.fail("/version", "1 (the scene format version this build reads)", root.contains("version") ? &root["version"] : nullptr);

    Scene scene;
    if (root.contains("objects")) {
        const json& objects = root["objects"];
        if (!objects.is_array()) r.fail("/objects", "an array of objects", &objects);
        for (std::size_t i = 0; i < objects.size(); ++i)
            scene.objects.push_back(readObject(r, objects[i], "/objects/" + std::to_string(i), i));
    }
    if (root.contains("lights")) {
        const json& lights = root["lights"];
        if (!lights.is_array()) r.fail("/lights", "an array of lights", &lights);
        if (lights.size() > 4) r.fail("/lights", "at most 4 lights (shadow map budget)", nullptr);
        std::optional<std::size_t> estimated;
        for (std::size_t i = 0; i < lights.size(); ++i) {
            const std::string p = "/lights/" + std::to_string(i);
            scene.lights.push_back(readLight(r, lights[i], p));
            if (scene.lights.back().type != LightType::Estimated) continue;
            // One estimator gives one dominant light: a second entry would be the same light twice.
            if (estimated)
                r.fail(p + "/type",
                       "at most one light of type \"estimated\" (lights/" + std::to_string(*estimated) +
                           " is one already)",
                       &lights[i]["type"]);
            estimated = i;
        }
    }
    scene.gi = gi::readGiSettings(r, root.contains("gi") ? root["gi"] : json::object(), "/gi");
    if (root.contains("tracking")) {
        r.object(root["tracking"], "/tracking");
        scene.trackingJson = root["tracking"].dump();
    }
    if (root.contains("roomModel")) {
        r.object(root["roomModel"], "/roomModel");
        scene.roomModelJson = root["roomModel"].dump();
    }
    if (root.contains("exposureStops")) scene.exposureStops = r.number(root["exposureStops"], "/exposureStops", -20.0f, 20.0f, "in [-20, 20] (stops)");
    if (root.contains("compositing")) {
        const json& c = root["compositing"];
        r.object(c, "/compositing");
        r.allowOnly(c, "/compositing", {"softBandSigmas", "minSoftBandMetres", "differential"});
        if (c.contains("softBandSigmas"))
            scene.compositing.softBandSigmas = r.number(c["softBandSigmas"], "/compositing/softBandSigmas", 0.0f, 100.0f, "in [0, 100]");
        if (c.contains("minSoftBandMetres"))
            scene.compositing.minSoftBandMetres = r.number(c["minSoftBandMetres"], "/compositing/minSoftBandMetres", 0.0f, 1.0f, "in [0, 1] metres");
        if (c.contains("differential"))
            scene.compositing.differential = r.boolean(c["differential"], "/compositing/differential");
    }
    return scene;
}

Scene loadScene(const std::filesystem::path& path) {
    std::ifstream file(path, std::ios::binary);
    if (!file) throw Error(path.string(), std::nullopt, "cannot open the scene file");
    const auto size = std::filesystem::file_size(path);
    if (size > 16u * 1024u * 1024u) throw Error(path.string(), std::nullopt, "scene file is larger than 16 MiB");
    std::ostringstream text;
    text << file.rdbuf();
    Scene scene = parseScene(text.str(), path.parent_path(), path.string());
    scene.file = path;
    return scene;
}

} // namespace lightskin::render
