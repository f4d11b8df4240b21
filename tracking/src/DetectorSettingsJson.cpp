#include <lightskin/core/Error.h>
#include <lightskin/core/JsonError.h>
#include <lightskin/tracking/TagDetector.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace lightskin::tracking {

namespace {

/// A number as a user wrote it ("-2", "0.5"), not std::to_string's "-2.000000".
template <typename T>
std::string shortNumber(T value) {
    std::ostringstream text;
    text << value;
    return text.str();
}

template <typename T>
std::optional<DetectorSettingProblem> outside(const char* key, T value, T min, T max) {
    // Written so that NaN is out of range too.
    if (value >= min && value <= max) return std::nullopt;
    const bool integral = std::is_integral_v<T>;
    return DetectorSettingProblem{key, std::string("expected ") + (integral ? "an integer" : "a number") + " in [" +
                                           shortNumber(min) + ", " + shortNumber(max) + "], got " + shortNumber(value)};
}

} // namespace

std::optional<DetectorSettingProblem> findDetectorSettingProblem(const DetectorSettings& settings) {
    const std::vector<std::string> families = supportedTagFamilies();
    if (std::find(families.begin(), families.end(), settings.family) == families.end()) {
        std::string known;
        for (const std::string& name : families) known += (known.empty() ? "" : ", ") + name;
        return DetectorSettingProblem{"family", "expected one of: " + known + "; got \"" + settings.family + "\""};
    }
    // The ranges libapriltag 3.3 accepts or that make sense for it: decimation by 1..16 (more leaves
    // no quads), blur sigma 0..10 px, 1..64 threads, sharpening 0..10, at most 2 corrected bits.
    if (auto p = outside("quadDecimate", settings.quadDecimate, 1.0f, 16.0f)) return p;
    if (auto p = outside("quadSigma", settings.quadSigma, 0.0f, 10.0f)) return p;
    if (auto p = outside("threads", settings.threads, 1, 64)) return p;
    if (auto p = outside("decodeSharpening", settings.decodeSharpening, 0.0, 10.0)) return p;
    if (auto p = outside("upsample", settings.upsample, 1, 4)) return p;
    if (auto p = outside("maxHamming", settings.maxHamming, 0, 2)) return p;
    // A decision margin is a grey-level distance (0..255); a negative one would accept every decode.
    if (auto p = outside("minDecisionMargin", settings.minDecisionMargin, 0.0f, 255.0f)) return p;
    return std::nullopt;
}

DetectorSettings detectorSettingsFromJson(const std::string& jsonObjectText, const std::string& sourceName,
                                          const std::string& pointer, const DetectorSettings& defaults) {
    // The scene file's error format (render/src/Scene.cpp): "<file>: <pointer>: expected ..., got ...".
    const auto fail = [&](const std::string& key, const std::string& cause) {
        throw Error(sourceName, std::nullopt, pointer + (key.empty() ? "" : "/" + key) + ": " + cause);
    };
    nlohmann::json json;
    try {
        json = nlohmann::json::parse(jsonObjectText);
    } catch (const nlohmann::json::exception& error) {
        throw Error(sourceName, std::nullopt, "not valid JSON: " + jsonErrorCause(error.what()));
    }
    if (!json.is_object())
        fail({}, "expected an object of detector settings (e.g. {\"quadDecimate\": 1}), got " + json.dump());
    DetectorSettings settings = defaults;
    for (const auto& item : json.items()) {
        // Plain references, not a structured binding: clang 15 (the fuzz build) cannot capture one.
        const std::string& key = item.key();
        const nlohmann::json& value = item.value();
        const auto expect = [&](bool ok, const char* what) {
            if (!ok) fail(key, std::string("expected ") + what + ", got " + value.dump());
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
            fail(key, "unknown key; expected one of: family, quadDecimate, quadSigma, threads, refineEdges, "
                      "decodeSharpening, refineCorners, maxHamming, minDecisionMargin, upsample");
        }
        // Integers that do not fit an int (1e10 as "threads") were converted above: check the JSON
        // value, so the message shows what the file says.
        if (value.is_number_integer() && (value.get<double>() < -1e9 || value.get<double>() > 1e9))
            fail(key, "expected a value in range, got " + value.dump());
    }
    // Ranges, so that the file and key are named here rather than by TagDetector::create later.
    if (const auto problem = findDetectorSettingProblem(settings)) {
        // Name only keys the file gave: a default cannot be out of range.
        const std::string got = json.contains(problem->key) ? json[problem->key].dump() : std::string();
        std::string cause = problem->cause;
        if (!got.empty() && problem->key != "family") cause = cause.substr(0, cause.rfind(", got ")) + ", got " + got;
        fail(problem->key, cause);
    }
    return settings;
}

} // namespace lightskin::tracking
