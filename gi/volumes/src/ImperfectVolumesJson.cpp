#include <lightskin/core/Error.h>
#include <lightskin/gi/volumes/ImperfectVolumesJson.h>

#include <nlohmann/json.hpp>

#include <string>

namespace lightskin::gi {

using nlohmann::json;

ImperfectVolumesSettings readImperfectVolumesSettings(const JsonReader& r, const json& value, const std::string& p) {
    r.object(value, p);
    r.allowOnly(value, p,
                {"resolution", "pointsPerTriangle", "raysPerVoxel", "bounces", "ambientOcclusion", "aoRange", "margin",
                 "origin", "size", "realAlbedo", "seed", "jitter", "temporalBlend"});
    ImperfectVolumesSettings v;
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

} // namespace lightskin::gi
