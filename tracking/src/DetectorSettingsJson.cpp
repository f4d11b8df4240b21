#include <lightskin/core/Error.h>
#include <lightskin/tracking/TagDetector.h>

#include <nlohmann/json.hpp>

namespace lightskin::tracking {

DetectorSettings detectorSettingsFromJson(const std::string& jsonObjectText, const std::string& sourceName,
                                          const DetectorSettings& defaults) {
    nlohmann::json json;
    try {
        json = nlohmann::json::parse(jsonObjectText);
    } catch (const nlohmann::json::exception& error) {
        throw Error(sourceName, std::nullopt, std::string("malformed JSON: ") + error.what());
    }
    if (!json.is_object()) throw Error(sourceName, std::nullopt, "detector settings must be a JSON object");
    DetectorSettings settings = defaults;
    for (const auto& item : json.items()) {
        // Plain references, not a structured binding: clang 15 (the fuzz build) cannot capture one.
        const std::string& key = item.key();
        const nlohmann::json& value = item.value();
        const auto expect = [&](bool ok, const char* what) {
            if (!ok) throw Error(sourceName, std::nullopt, "/" + key + ": expected " + what + ", got " + value.dump());
        };
        if (key == "family") {
            expect(value.is_string(), "a tag family name");
            settings.family = value.get<std::string>();
        } else if (key == "quadDecimate") {
            expect(value.is_number(), "a number");
            settings.quadDecimate = value.get<float>();
        } else if (key == "quadSigma") {
            expect(value.is_number(), "a number");
            settings.quadSigma = value.get<float>();
        } else if (key == "threads") {
            expect(value.is_number_integer(), "an integer");
            settings.threads = value.get<int>();
        } else if (key == "refineEdges") {
            expect(value.is_boolean(), "true or false");
            settings.refineEdges = value.get<bool>();
        } else if (key == "decodeSharpening") {
            expect(value.is_number(), "a number");
            settings.decodeSharpening = value.get<double>();
        } else if (key == "refineCorners") {
            expect(value.is_boolean(), "true or false");
            settings.refineCorners = value.get<bool>();
        } else if (key == "maxHamming") {
            expect(value.is_number_integer(), "an integer");
            settings.maxHamming = value.get<int>();
        } else if (key == "minDecisionMargin") {
            expect(value.is_number(), "a number");
            settings.minDecisionMargin = value.get<float>();
        } else if (key == "upsample") {
            expect(value.is_number_integer(), "an integer");
            settings.upsample = value.get<int>();
        } else {
            throw Error(sourceName, std::nullopt,
                        "/" + key +
                            ": unknown detector setting (known: family, quadDecimate, quadSigma, threads, "
                            "refineEdges, decodeSharpening, refineCorners, maxHamming, minDecisionMargin, "
                            "upsample)");
        }
    }
    return settings;
}

} // namespace lightskin::tracking
