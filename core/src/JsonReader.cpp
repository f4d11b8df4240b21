#include <lightskin/core/Error.h>
#include <lightskin/core/JsonReader.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <optional>
#include <utility>

namespace lightskin {

using nlohmann::json;

JsonReader::JsonReader(std::string source, std::filesystem::path baseFolder)
    : source_(std::move(source))
    , base_(std::move(baseFolder)) {}

void JsonReader::fail(const std::string& pointer, const std::string& expected, const json* got) const {
    std::string cause = (pointer.empty() ? std::string("/") : pointer) + ": expected " + expected;
    if (got != nullptr) {
        std::string text = got->dump();
        if (text.size() > 60) text = text.substr(0, 57) + "...";
        cause += ", got " + text;
    }
    throw Error(source_, std::nullopt, cause);
}

void JsonReader::allowOnly(const json& object, const std::string& pointer,
                           std::initializer_list<const char*> keys) const {
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

const json& JsonReader::object(const json& value, const std::string& pointer) const {
    if (!value.is_object()) fail(pointer, "an object", &value);
    return value;
}

float JsonReader::number(const json& value, const std::string& pointer, float min, float max, const char* what) const {
    if (!value.is_number()) fail(pointer, std::string("a number ") + what, &value);
    const double v = value.get<double>();
    if (!std::isfinite(v) || v < double(min) || v > double(max)) fail(pointer, std::string("a number ") + what, &value);
    return float(v);
}

int JsonReader::integer(const json& value, const std::string& pointer, int min, int max) const {
    const std::string what = "an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "]";
    if (!value.is_number_integer()) fail(pointer, what, &value);
    const auto v = value.get<std::int64_t>();
    if (v < min || v > max) fail(pointer, what, &value);
    return int(v);
}

bool JsonReader::boolean(const json& value, const std::string& pointer) const {
    if (!value.is_boolean()) fail(pointer, "true or false", &value);
    return value.get<bool>();
}

std::string JsonReader::string(const json& value, const std::string& pointer) const {
    if (!value.is_string() || value.get<std::string>().empty()) fail(pointer, "a non-empty string", &value);
    return value.get<std::string>();
}

glm::vec3 JsonReader::vec3(const json& value, const std::string& pointer, float min, float max,
                           const char* what) const {
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

glm::vec3 JsonReader::colour(const json& value, const std::string& pointer, float max, const char* what) const {
    if (value.is_number()) return glm::vec3(number(value, pointer, 0.0f, max, what));
    return vec3(value, pointer, 0.0f, max, what);
}

std::filesystem::path JsonReader::existingFile(const json& value, const std::string& pointer, const char* what) const {
    const std::filesystem::path relative = string(value, pointer);
    const std::filesystem::path path = (base_ / relative).lexically_normal();
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        throw Error(source_, std::nullopt, pointer + ": " + what + " '" + path.string() + "' does not exist");
    return path;
}

} // namespace lightskin
