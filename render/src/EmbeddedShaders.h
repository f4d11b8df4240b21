#pragma once
// The render module's shaders, embedded at build time (render/shaders/).
#include <lightskin/gl/EmbeddedFile.h>

#include <span>

namespace lightskin::render {
std::span<const gl::EmbeddedFile> embeddedShaders();
} // namespace lightskin::render
