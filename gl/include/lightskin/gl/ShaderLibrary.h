#pragma once
// Looks up embedded shader files by name, resolves `#include "name"` between them, inserts
// `#define` variants after the `#version` line, and compiles programs. Compilation errors name
// the shader file and its variant.

#include <lightskin/gl/EmbeddedFile.h>
#include <lightskin/gl/Objects.h>

#include <initializer_list>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace lightskin::gl {

struct ShaderStage {
    GLenum stage;          ///< GL_VERTEX_SHADER, GL_FRAGMENT_SHADER, GL_COMPUTE_SHADER, ...
    std::string_view name; ///< embedded file name
};

class ShaderLibrary {
public:
    /// `tables`: the embedded files of each module to search, in order (first match wins).
    /// The gl module's own table (fullscreen.vert, ...) is always searched last.
    explicit ShaderLibrary(std::initializer_list<std::span<const EmbeddedFile>> tables);

    /// The file's bytes as embedded; throws lightskin::Error if there is no such file.
    std::string_view raw(std::string_view name) const;

    /// The file with includes resolved (each file at most once) and `defines` ("NAME" or
    /// "NAME VALUE") inserted after its `#version` line.
    std::string preprocess(std::string_view name, std::span<const std::string> defines = {}) const;

    Program buildProgram(std::initializer_list<ShaderStage> stages, std::span<const std::string> defines = {}) const;

private:
    void appendResolved(std::string_view name, std::string& out, std::vector<std::string_view>& included,
                        int depth) const;
    std::vector<std::span<const EmbeddedFile>> tables_;
};

} // namespace lightskin::gl
