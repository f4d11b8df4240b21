#include <lightskin/core/Error.h>
#include <lightskin/core/JsonError.h>
#include <lightskin/render/Scene.h>

#include <nlohmann/json.hpp>

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <sstream>

namespace lightskin::render {

namespace {

using nlohmann::json;

/// Walks the JSON with the current pointer so every error names its key.
class Reader {
public:
    Reader(std::string source, std::filesystem::path baseFolder) : source_(std::move(source)), base_(std::move(baseFolder)) {}

    [[noreturn]] void fail(const std::string& pointer, const std::string& expected, const json* got) const {
        std::string cause = (pointer.empty() ? std::string("/") : pointer) + ": expected " + expected;
        if (got != nullptr) {
            std::string text = got->dump();
            if (text.size() > 60) text = text.substr(0, 57) + "...";
            cause += ", got " + text;
        }
        throw Error(source_, std::nullopt, cause);
    }

    void allowOnly(const json& object, const std::string& pointer, std::initializer_list<const char*> keys) const {
        for (const auto& [key, value] : object.items()) {
            bool known = false;
            for (const char* allowed : keys) known = known || key == allowed;
            if (!known) {
                std::string list;
                for (const char* allowed : keys) list += std::string(list.empty() ? "" : ", ") + allowed;
                throw Error(source_, std::nullopt, pointer + "/" + key + ": unknown key; expected one of: " + list);
            }
        }
    }

    const json& object(const json& parent, const std::string& pointer) const {
        if (!parent.is_object()) fail(pointer, "an object", &parent);
        return parent;
    }

    float number(const json& value, const std::string& pointer, float min, float max, const char* what) const {
        if (!value.is_number()) fail(pointer, std::string("a number ") + what, &value);
        const double v = value.get<double>();
        if (!std::isfinite(v) || v < double(min) || v > double(max)) fail(pointer, std::string("a number ") + what, &value);
        return float(v);
    }

    int integer(const json& value, const std::string& pointer, int min, int max) const {
        const std::string what = "an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "]";
        if (!value.is_number_integer()) fail(pointer, what, &value);
        const auto v = value.get<std::int64_t>();
        if (v < min || v > max) fail(pointer, what, &value);
        return int(v);
    }

    bool boolean(const json& value, const std::string& pointer) const {
        if (!value.is_boolean()) fail(pointer, "true or false", &value);
        return value.get<bool>();
    }

    std::string string(const json& value, const std::string& pointer) const {
        if (!value.is_string() || value.get<std::string>().empty()) fail(pointer, "a non-empty string", &value);
        return value.get<std::string>();
    }

    glm::vec3 vec3(const json& value, const std::string& pointer, float min, float max, const char* what) const {
        const std::string expected = std::string("an array of 3 numbers ") + what;
        if (!value.is_array() || value.size() != 3) fail(pointer, expected, &value);
        glm::vec3 v;
        for (int i = 0; i < 3; ++i) {
            const json& c = value[std::size_t(i)];
            if (!c.is_number()) fail(pointer + "/" + std::to_string(i), std::string("a number ") + what, &c);
            const double d = c.get<double>();
            if (!std::isfinite(d) || d < double(min) || d > double(max))
                fail(pointer + "/" + std::to_string(i), std::string("a number ") + what, &c);
            v[i] = float(d);
        }
        return v;
    }

    /// An RGB colour: [r,g,b] or one number for grey.
    glm::vec3 colour(const json& value, const std::string& pointer, float max, const char* what) const {
        if (value.is_number()) return glm::vec3(number(value, pointer, 0.0f, max, what));
        return vec3(value, pointer, 0.0f, max, what);
    }

    std::filesystem::path existingFile(const json& value, const std::string& pointer, const char* what) const {
        const std::filesystem::path relative = string(value, pointer);
        const std::filesystem::path path = (base_ / relative).lexically_normal();
        std::error_code ec;
        if (!std::filesystem::is_regular_file(path, ec))
            throw Error(source_, std::nullopt, pointer + ": " + what + " '" + path.string() + "' does not exist");
        return path;
    }

private:
    std::string source_;
    std::filesystem::path base_;
};

MaterialOverride readMaterial(const Reader& r, const json& value, const std::string& p) {
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

glm::mat4 readTransform(const Reader& r, const json& value, const std::string& p) {
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

SceneObject readObject(const Reader& r, const json& value, const std::string& p, std::size_t index) {
    r.object(value, p);
    r.allowOnly(value, p, {"name", "mesh", "transform", "material"});
    SceneObject o;
    o.name = value.contains("name") ? r.string(value["name"], p + "/name") : "object" + std::to_string(index);
    if (!value.contains("mesh")) r.fail(p + "/mesh", "a mesh file path (OBJ, PLY or glTF; relative to the scene file)", nullptr);
    o.mesh = r.existingFile(value["mesh"], p + "/mesh", "mesh file");
    if (value.contains("transform")) o.world_T_model = readTransform(r, value["transform"], p + "/transform");
    if (value.contains("material")) o.material = readMaterial(r, value["material"], p + "/material");
    return o;
}

SceneLight readLight(const Reader& r, const json& value, const std::string& p) {
    r.object(value, p);
    r.allowOnly(
        value, p,
        {"type", "position", "direction", "power", "coneAngleDegrees", "coneFalloffDegrees", "shadows", "inRoom"});
    SceneLight l;
    const std::string type = value.contains("type") ? r.string(value["type"], p + "/type") : "";
    if (type == "point") l.type = LightType::Point;
    else if (type == "spot") l.type = LightType::Spot;
    else r.fail(p + "/type", "\"point\" or \"spot\"", value.contains("type") ? &value["type"] : nullptr);
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
    return l;
}

// Ranges as gi::validate(ImperfectVolumesSettings) checks them, here with the key's JSON pointer.
gi::ImperfectVolumesSettings readImperfectVolumes(const Reader& r, const json& value, const std::string& p) {
    r.object(value, p);
    r.allowOnly(value, p,
                {"resolution", "pointsPerTriangle", "raysPerVoxel", "bounces", "ambientOcclusion", "aoRange", "margin",
                 "origin", "size", "realAlbedo", "seed", "jitter", "temporalBlend"});
    gi::ImperfectVolumesSettings v;
    if (value.contains("resolution")) v.resolution = r.integer(value["resolution"], p + "/resolution", 1, 256);
    if (value.contains("pointsPerTriangle"))
        v.pointsPerTriangle = r.integer(value["pointsPerTriangle"], p + "/pointsPerTriangle", 0, 256);
    if (value.contains("raysPerVoxel")) v.raysPerVoxel = r.integer(value["raysPerVoxel"], p + "/raysPerVoxel", 1, 4096);
    if (value.contains("bounces")) v.bounces = r.integer(value["bounces"], p + "/bounces", 1, 4);
    if (value.contains("ambientOcclusion"))
        v.ambientOcclusion = r.boolean(value["ambientOcclusion"], p + "/ambientOcclusion");
    if (value.contains("aoRange"))
        v.aoRange = r.number(value["aoRange"], p + "/aoRange", 1e-4f, 1e3f, "in [1e-4, 1000] (metres)");
    if (value.contains("margin"))
        v.margin = r.number(value["margin"], p + "/margin", 0.0f, 1e3f, "in [0, 1000] (metres)");
    // A fixed grid: both origin (minimum corner) and size (edge), instead of the auto-fit.
    if (value.contains("origin") != value.contains("size"))
        r.fail(p + (value.contains("origin") ? "/size" : "/origin"),
               "both \"origin\" and \"size\" for a fixed grid (or neither: auto-fit)", nullptr);
    if (value.contains("origin")) {
        v.autoFit = false;
        v.origin = r.vec3(value["origin"], p + "/origin", -1e4f, 1e4f, "(metres)");
        v.size = r.number(value["size"], p + "/size", 1e-3f, 1e4f, "in [0.001, 10000] (metres)");
    }
    if (value.contains("realAlbedo"))
        v.realAlbedo = r.number(value["realAlbedo"], p + "/realAlbedo", 0.0f, 1.0f, "in [0, 1]");
    if (value.contains("jitter")) v.jitter = r.boolean(value["jitter"], p + "/jitter");
    if (value.contains("temporalBlend"))
        v.temporalBlend = r.number(value["temporalBlend"], p + "/temporalBlend", 0.0f, 0.95f, "in [0, 0.95]");
    if (value.contains("seed")) v.seed = std::uint32_t(r.integer(value["seed"], p + "/seed", 0, 1 << 30));
    return v;
}

// Ranges as gi::validate(MultiscalePrtSettings) checks them. The cache folder is resolved against the
// scene's folder; by default "prt-cache" beside the scene (none for a scene parsed from text).
gi::MultiscalePrtSettings readMultiscalePrt(const Reader& r, const json& value, const std::string& p,
                                            const std::filesystem::path& baseFolder) {
    r.object(value, p);
    r.allowOnly(value, p,
                {"entryPoints", "walksPerEntry", "maxBounces", "clusters", "basisVectors", "obscuranceDistance",
                 "obscuranceRays", "minConnectionDistance", "seed", "cache", "cacheDir", "entryLightPoints",
                 "entryLightFraction", "gatherPoints"});
    gi::MultiscalePrtSettings v;
    if (value.contains("entryPoints")) v.entryPoints = r.integer(value["entryPoints"], p + "/entryPoints", 1, 65536);
    if (value.contains("walksPerEntry"))
        v.walksPerEntry = r.integer(value["walksPerEntry"], p + "/walksPerEntry", 1, 65536);
    if (value.contains("maxBounces")) v.maxBounces = r.integer(value["maxBounces"], p + "/maxBounces", 0, 64);
    if (value.contains("clusters")) v.clusters = r.integer(value["clusters"], p + "/clusters", 1, 65536);
    if (value.contains("basisVectors")) v.basisVectors = r.integer(value["basisVectors"], p + "/basisVectors", 0, 64);
    if (value.contains("obscuranceDistance"))
        v.obscuranceDistance =
            r.number(value["obscuranceDistance"], p + "/obscuranceDistance", 0.0f, 1e3f, "in [0, 1000] (metres)");
    if (value.contains("obscuranceRays"))
        v.obscuranceRays = r.integer(value["obscuranceRays"], p + "/obscuranceRays", 1, 4096);
    if (value.contains("minConnectionDistance"))
        v.minConnectionDistance =
            r.number(value["minConnectionDistance"], p + "/minConnectionDistance", 0.0f, 10.0f, "in [0, 10] (metres)");
    if (value.contains("seed")) v.seed = std::uint32_t(r.integer(value["seed"], p + "/seed", 0, 1 << 30));
    if (value.contains("entryLightPoints")) {
        const json& points = value["entryLightPoints"];
        if (!points.is_array()) r.fail(p + "/entryLightPoints", "an array of [x, y, z] positions (metres)", &points);
        for (std::size_t i = 0; i < points.size(); ++i)
            v.entryLightPoints.push_back(
                r.vec3(points[i], p + "/entryLightPoints/" + std::to_string(i), -1e4f, 1e4f, "(metres)"));
    }
    if (value.contains("entryLightFraction"))
        v.entryLightFraction = r.number(value["entryLightFraction"], p + "/entryLightFraction", 0.0f, 0.99f,
                                        "in [0, 0.99] (1 would leave surfaces without entry points)");
    if (value.contains("gatherPoints"))
        v.directGatherPoints = r.integer(value["gatherPoints"], p + "/gatherPoints", 0, 1 << 24);
    const bool cache = value.contains("cache") ? r.boolean(value["cache"], p + "/cache") : true;
    if (value.contains("cacheDir") && !cache)
        r.fail(p + "/cacheDir", "no cacheDir with \"cache\": false", &value["cacheDir"]);
    if (cache && !baseFolder.empty()) {
        const std::string folder =
            value.contains("cacheDir") ? r.string(value["cacheDir"], p + "/cacheDir") : std::string("prt-cache");
        if (folder.empty()) r.fail(p + "/cacheDir", "a folder path (relative to the scene file)", &value["cacheDir"]);
        v.cacheDirectory = (baseFolder / folder).lexically_normal();
    }
    return v;
}

GiSettings readGi(const Reader& r, const json& value, const std::string& p, const std::filesystem::path& baseFolder) {
    r.object(value, p);
    r.allowOnly(value, p,
                {"technique", "backend", "sparsePoints", "valStride", "kCache", "diffuse", "glossy", "occlusion",
                 "virtualBounce", "rsmResolution", "budgetMs", "robustRealDepth", "imperfectVolumes", "multiscalePrt",
                 "valTreeThreshold"});
    GiSettings g;
    if (value.contains("technique")) {
        const std::optional<gi::Technique> technique = gi::parseTechnique(r.string(value["technique"], p + "/technique"));
        if (!technique) r.fail(p + "/technique", gi::techniqueNames(true), &value["technique"]);
        g.technique = *technique;
    }
    if (value.contains("backend")) {
        const std::optional<gi::Backend> backend = gi::parseBackend(r.string(value["backend"], p + "/backend"));
        if (!backend) r.fail(p + "/backend", gi::backendNames(true), &value["backend"]);
        if (!gi::runsOn(g.technique, *backend))
            r.fail(p + "/backend", "\"gl\" (the CPU backend exists for technique \"lightskin\" only)",
                   &value["backend"]);
        g.backend = *backend;
    }
    if (value.contains("sparsePoints")) g.sparsePoints = r.integer(value["sparsePoints"], p + "/sparsePoints", 16, 65536);
    if (value.contains("valStride")) g.valStride = r.integer(value["valStride"], p + "/valStride", 1, 64);
    if (value.contains("kCache")) {
        g.kCache = r.integer(value["kCache"], p + "/kCache", 16, 4096);
        if (g.kCache % 16 != 0) r.fail(p + "/kCache", "a multiple of 16 (uniform-buffer alignment) in [16, 4096]", &value["kCache"]);
    }
    if (value.contains("diffuse")) g.diffuse = r.boolean(value["diffuse"], p + "/diffuse");
    if (value.contains("glossy")) g.glossy = r.boolean(value["glossy"], p + "/glossy");
    if (value.contains("occlusion")) g.occlusion = r.boolean(value["occlusion"], p + "/occlusion");
    if (value.contains("virtualBounce")) g.virtualBounce = r.boolean(value["virtualBounce"], p + "/virtualBounce");
    if (value.contains("rsmResolution")) g.rsmResolution = r.integer(value["rsmResolution"], p + "/rsmResolution", 8, 256);
    if (value.contains("budgetMs"))
        g.budgetMs =
            double(r.number(value["budgetMs"], p + "/budgetMs", 0.001f, 1.0e6f, "in [0.001, 1e6] (milliseconds)"));
    if (value.contains("robustRealDepth")) g.robustRealDepth = r.boolean(value["robustRealDepth"], p + "/robustRealDepth");
    if (value.contains("valTreeThreshold"))
        g.valTreeThreshold = r.number(value["valTreeThreshold"], p + "/valTreeThreshold", 0.0f, 100.0f, "in [0, 100]");
    if (value.contains("imperfectVolumes")) {
        if (g.technique != gi::Technique::ImperfectVolumes)
            r.fail(p + "/imperfectVolumes", "gi.technique \"imperfect-volumes\" (the key belongs to that technique)",
                   nullptr);
        g.imperfectVolumes = readImperfectVolumes(r, value["imperfectVolumes"], p + "/imperfectVolumes");
    }
    if (value.contains("multiscalePrt") && g.technique != gi::Technique::MultiscalePrt)
        r.fail(p + "/multiscalePrt", "gi.technique \"multiscale-prt\" (the key belongs to that technique)", nullptr);
    // Read also when absent: the default cache folder depends on the scene's folder.
    g.multiscalePrt = readMultiscalePrt(r, value.contains("multiscalePrt") ? value["multiscalePrt"] : json::object(),
                                        p + "/multiscalePrt", baseFolder);
    return g;
}

} // namespace

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
    const Reader r(sourceName, baseFolder);
    r.object(root, "");
    r.allowOnly(root, "", {"version", "objects", "lights", "gi", "tracking", "exposureStops", "compositing", "description"});
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
        for (std::size_t i = 0; i < lights.size(); ++i) scene.lights.push_back(readLight(r, lights[i], "/lights/" + std::to_string(i)));
    }
    scene.gi = readGi(r, root.contains("gi") ? root["gi"] : json::object(), "/gi", baseFolder);
    if (root.contains("tracking")) {
        r.object(root["tracking"], "/tracking");
        scene.trackingJson = root["tracking"].dump();
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
