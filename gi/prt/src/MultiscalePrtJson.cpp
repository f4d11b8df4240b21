#include <lightskin/core/Error.h>
#include <lightskin/gi/prt/MultiscalePrtJson.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

namespace lightskin::gi {

using nlohmann::json;

MultiscalePrtSettings readMultiscalePrtSettings(const JsonReader& r, const json& value, const std::string& p) {
    const std::filesystem::path& baseFolder = r.baseFolder();
    r.object(value, p);
    r.allowOnly(value, p,
                {"entryPoints", "walksPerEntry", "maxBounces", "clusters", "basisVectors", "obscuranceDistance",
                 "obscuranceRays", "minConnectionDistance", "seed", "cache", "cacheDir", "entryLightPoints",
                 "entryLightFraction", "gatherPoints"});
    MultiscalePrtSettings v;
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

} // namespace lightskin::gi
