#pragma once
// Typed, range-checked reads from a JSON document whose every error names the key: each read takes the
// value and its JSON pointer ("/gi/sparsePoints") and throws lightskin::Error (core/Error.h) naming the
// document (`source`, e.g. the scene file), the pointer, what was expected and (shortened) what was found.

#include <glm/vec3.hpp>
#include <nlohmann/json_fwd.hpp>

#include <filesystem>
#include <initializer_list>
#include <string>

namespace lightskin {

class JsonReader {
public:
    /// `source` names the document in errors; `baseFolder` resolves relative file paths (existingFile()).
    JsonReader(std::string source, std::filesystem::path baseFolder);

    const std::string& source() const { return source_; }
    const std::filesystem::path& baseFolder() const { return base_; }

    /// Throws "<pointer>: expected <expected>[, got <got>]".
    [[noreturn]] void fail(const std::string& pointer, const std::string& expected, const nlohmann::json* got) const;
    /// Throws for a key of `object` not in `keys`, listing them.
    void allowOnly(const nlohmann::json& object, const std::string& pointer,
                   std::initializer_list<const char*> keys) const;
    /// `value` itself when it is an object.
    const nlohmann::json& object(const nlohmann::json& value, const std::string& pointer) const;
    /// A finite number in [min, max]; `what` describes the range and unit in the error, e.g. "in [0, 1] (metres)".
    float number(const nlohmann::json& value, const std::string& pointer, float min, float max, const char* what) const;
    int integer(const nlohmann::json& value, const std::string& pointer, int min, int max) const;
    bool boolean(const nlohmann::json& value, const std::string& pointer) const;
    std::string string(const nlohmann::json& value, const std::string& pointer) const; ///< non-empty
    glm::vec3 vec3(const nlohmann::json& value, const std::string& pointer, float min, float max,
                   const char* what) const;
    /// An RGB colour in [0, max]: [r, g, b] or one number for grey.
    glm::vec3 colour(const nlohmann::json& value, const std::string& pointer, float max, const char* what) const;
    /// A path relative to baseFolder() naming an existing regular file; `what` names it in the error ("texture").
    std::filesystem::path existingFile(const nlohmann::json& value, const std::string& pointer, const char* what) const;

private:
    std::string source_;
    std::filesystem::path base_;
};

} // namespace lightskin
