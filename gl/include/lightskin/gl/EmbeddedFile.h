#pragma once
// A file compiled into the binary (shaders). Generated tables of these are produced by
// cmake/EmbedFiles.cmake; each module that has shaders exposes
//   std::span<const lightskin::gl::EmbeddedFile> <module namespace>::embeddedShaders();

#include <span>
#include <string_view>

namespace lightskin::gl {

struct EmbeddedFile {
    std::string_view name;     ///< path relative to the module's shaders/ folder, e.g. "gather.frag"
    std::string_view contents; ///< the file's bytes (static storage, not NUL-terminated by contract)
};

/// The gl module's own shaders (fullscreen triangle, self-test shaders).
std::span<const EmbeddedFile> embeddedShaders();

} // namespace lightskin::gl
