#include <lightskin/core/Error.h>
#include <lightskin/gi/Techniques.h>
#include <lightskin/gi/prt/MultiscalePrtJson.h>
#include <lightskin/gi/volumes/ImperfectVolumesJson.h>

#include <nlohmann/json.hpp>

#include <optional>
#include <string>

namespace lightskin::gi {

using nlohmann::json;

GiSettings readGiSettings(const JsonReader& r, const json& value, const std::string& p) {
    r.object(value, p);
    r.allowOnly(value, p,
                {"technique", "backend", "sparsePoints", "valStride", "kCache", "diffuse", "glossy", "occlusion",
                 "virtualBounce", "rsmResolution", "budgetMs", "robustRealDepth", "imperfectVolumes", "multiscalePrt",
                 "valTreeThreshold"});
    GiSettings g;
    if (value.contains("technique")) {
        const std::optional<Technique> technique = parseTechnique(r.string(value["technique"], p + "/technique"));
        if (!technique) r.fail(p + "/technique", techniqueNames(true), &value["technique"]);
        g.technique = *technique;
    }
    if (value.contains("backend")) {
        const std::optional<BackendSetting> backend = parseBackendSetting(r.string(value["backend"], p + "/backend"));
        if (!backend) r.fail(p + "/backend", backendSettingNames(true), &value["backend"]);
        if (*backend == BackendSetting::Cpu && !runsOn(g.technique, Backend::Cpu))
            r.fail(p + "/backend", "\"auto\" or \"gl\" (the CPU backend exists for technique \"lightskin\" only)",
                   &value["backend"]);
        g.backend = *backend;
    }
    if (value.contains("sparsePoints"))
        g.sparsePoints = r.integer(value["sparsePoints"], p + "/sparsePoints", 16, 65536);
    if (value.contains("valStride")) g.valStride = r.integer(value["valStride"], p + "/valStride", 1, 64);
    if (value.contains("kCache")) {
        g.kCache = r.integer(value["kCache"], p + "/kCache", 16, 4096);
        if (g.kCache % 16 != 0)
            r.fail(p + "/kCache", "a multiple of 16 (uniform-buffer alignment) in [16, 4096]", &value["kCache"]);
    }
    if (value.contains("diffuse")) g.diffuse = r.boolean(value["diffuse"], p + "/diffuse");
    if (value.contains("glossy")) g.glossy = r.boolean(value["glossy"], p + "/glossy");
    if (value.contains("occlusion")) g.occlusion = r.boolean(value["occlusion"], p + "/occlusion");
    if (value.contains("virtualBounce")) g.virtualBounce = r.boolean(value["virtualBounce"], p + "/virtualBounce");
    if (value.contains("rsmResolution"))
        g.rsmResolution = r.integer(value["rsmResolution"], p + "/rsmResolution", 8, 256);
    if (value.contains("budgetMs"))
        g.budgetMs =
            double(r.number(value["budgetMs"], p + "/budgetMs", 0.001f, 1.0e6f, "in [0.001, 1e6] (milliseconds)"));
    if (value.contains("robustRealDepth"))
        g.robustRealDepth = r.boolean(value["robustRealDepth"], p + "/robustRealDepth");
    if (value.contains("valTreeThreshold")) {
        const json& tree = value["valTreeThreshold"];
        if (tree.is_string() && tree.get<std::string>() == "auto")
            g.valTreeThreshold.reset();
        else if (tree.is_number())
            g.valTreeThreshold = r.number(tree, p + "/valTreeThreshold", 0.0f, 100.0f, "in [0, 100] or \"auto\"");
        else
            r.fail(p + "/valTreeThreshold", "a number in [0, 100] or \"auto\"", &tree);
    }
    if (value.contains("imperfectVolumes")) {
        if (g.technique != Technique::ImperfectVolumes)
            r.fail(p + "/imperfectVolumes", "gi.technique \"imperfect-volumes\" (the key belongs to that technique)",
                   nullptr);
        g.imperfectVolumes = readImperfectVolumesSettings(r, value["imperfectVolumes"], p + "/imperfectVolumes");
    }
    if (value.contains("multiscalePrt") && g.technique != Technique::MultiscalePrt)
        r.fail(p + "/multiscalePrt", "gi.technique \"multiscale-prt\" (the key belongs to that technique)", nullptr);
    // Read also when absent: the default cache folder depends on the scene's folder.
    g.multiscalePrt = readMultiscalePrtSettings(
        r, value.contains("multiscalePrt") ? value["multiscalePrt"] : json::object(), p + "/multiscalePrt");
    return g;
}

} // namespace lightskin::gi
