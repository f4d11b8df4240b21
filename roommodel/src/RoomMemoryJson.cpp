#include <lightskin/core/Error.h>
#include <lightskin/core/JsonError.h>
#include <lightskin/roommodel/RoomMemory.h>

#include <nlohmann/json.hpp>

#include <functional>
#include <map>

namespace lightskin::roommodel {

namespace {

using Json = nlohmann::json;
using Fail = std::function<void(const std::string& key, const std::string& cause)>;
using Reader = std::function<void(const std::string& key, const Json& value)>;

/// Reads every key of `object` with its reader; an unknown key fails with the list of known ones.
void readObject(const Json& object, const std::map<std::string, Reader>& readers, const std::string& prefix,
                const Fail& fail) {
    if (!object.is_object()) fail(prefix, "expected an object, got " + object.dump());
    for (const auto& item : object.items()) {
        const auto reader = readers.find(item.key());
        if (reader == readers.end()) {
            std::string known;
            for (const auto& [key, unused] : readers) known += (known.empty() ? "" : ", ") + key;
            fail(prefix + item.key(), "unknown key; expected one of: " + known);
        }
        reader->second(prefix + item.key(), item.value());
    }
}

Reader number(double& out, const Fail& fail) {
    return [&out, fail](const std::string& key, const Json& v) {
        if (!v.is_number()) fail(key, "expected a number, got " + v.dump());
        out = v.get<double>();
    };
}

Reader integer(int& out, const Fail& fail) {
    return [&out, fail](const std::string& key, const Json& v) {
        if (!v.is_number_integer() || v.get<double>() < -1e9 || v.get<double>() > 1e9)
            fail(key, "expected an integer, got " + v.dump());
        out = v.get<int>();
    };
}

Reader boolean(bool& out, const Fail& fail) {
    return [&out, fail](const std::string& key, const Json& v) {
        if (!v.is_boolean()) fail(key, "expected true or false, got " + v.dump());
        out = v.get<bool>();
    };
}

Reader point(glm::dvec3& out, const Fail& fail) {
    return [&out, fail](const std::string& key, const Json& v) {
        if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number())
            fail(key, "expected [x, y, z] in metres, got " + v.dump());
        out = glm::dvec3(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
    };
}

} // namespace

RoomMemorySettings roomMemorySettingsFromJson(const std::string& jsonObjectText, const std::string& sourceName,
                                              const std::string& pointer) {
    const Fail fail = [&](const std::string& key, const std::string& cause) {
        throw Error(sourceName, std::nullopt, pointer + (key.empty() ? "" : "/" + key) + ": " + cause);
    };
    Json json;
    try {
        json = Json::parse(jsonObjectText);
    } catch (const Json::exception& error) {
        throw Error(sourceName, std::nullopt, pointer + ": not valid JSON: " + jsonErrorCause(error.what()));
    }
    RoomMemorySettings s;
    RoomModelSettings& m = s.model;
    DepthTrackingSettings& d = s.depthTracking;
    const std::map<std::string, Reader> bounds{{"min", point(m.boundsMin, fail)}, {"max", point(m.boundsMax, fail)}};
    const std::map<std::string, Reader> tracking{{"enabled", boolean(d.enabled, fail)},
                                                 {"blendFrames", integer(d.blendFrames, fail)},
                                                 {"maxFrames", integer(d.maxFrames, fail)},
                                                 {"trackingWidth", integer(d.trackingWidth, fail)},
                                                 {"maxCorrectionMetres", number(d.maxCorrectionMetres, fail)},
                                                 {"maxCorrectionDegrees", number(d.maxCorrectionDegrees, fail)},
                                                 {"minValidFraction", number(d.minValidFraction, fail)},
                                                 {"minConstraintRatio", number(d.minConstraintRatio, fail)}};
    const std::map<std::string, Reader> root{
        {"bounds", [&](const std::string& key, const Json& v) { readObject(v, bounds, key + "/", fail); }},
        {"up", point(m.up, fail)},
        {"voxelSizeMetres", number(m.voxelSizeMetres, fail)},
        {"truncationMetres", number(m.truncationMetres, fail)},
        {"maxWeight", integer(m.maxWeight, fail)},
        {"maxDepthMetres", number(m.maxDepthMetres, fail)},
        {"memoryBudgetMB", number(m.memoryBudgetMB, fail)},
        {"processingWidth", integer(s.processingWidth, fail)},
        {"depthTracking", [&](const std::string& key, const Json& v) { readObject(v, tracking, key + "/", fail); }}};
    readObject(json, root, "", fail);
    validate(s, sourceName, pointer);
    return s;
}

} // namespace lightskin::roommodel
