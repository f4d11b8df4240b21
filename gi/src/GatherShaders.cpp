#include "GatherShaders.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>

#include <algorithm>

namespace lightskin::gi::detail {

void ValChunkBuffer::validateKCache(int kCache, const char* who) {
    GLint maxBlock = 0;
    glGetIntegerv(GL_MAX_UNIFORM_BLOCK_SIZE, &maxBlock);
    GLint alignment = 0;
    glGetIntegerv(GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT, &alignment);
    if (kCache <= 0 || kCache % 16 != 0)
        throw Error(who, std::nullopt, "kCache must be a positive multiple of 16, got " + std::to_string(kCache));
    if (std::int64_t(kCache) * kValBytes > maxBlock)
        throw Error(who, std::nullopt,
                    "kCache " + std::to_string(kCache) + " exceeds GL_MAX_UNIFORM_BLOCK_SIZE " + std::to_string(maxBlock));
    if (alignment > 0 && (std::int64_t(kCache) * kValBytes) % alignment != 0)
        throw Error(who, std::nullopt, "kCache * 48 bytes must be a multiple of GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT " +
                                           std::to_string(alignment));
}

void ValChunkBuffer::reserve(std::uint32_t capacity, int kCache) {
    const std::uint32_t k = std::uint32_t(kCache);
    const std::uint32_t rounded = std::max<std::uint32_t>(1, (capacity + k - 1) / k) * k;
    if (buffer_ && rounded <= capacity_ && kCache == kCache_) return;
    if (buffer_) log::info("lightskin: VAL buffer grows to " + std::to_string(rounded) + " lights");
    kCache_ = kCache;
    capacity_ = rounded;
    buffer_ = gl::Buffer::create(GLsizeiptr(capacity_) * kValBytes, nullptr, GL_DYNAMIC_STORAGE_BIT);
}

void ValChunkBuffer::copyFrom(std::uint32_t source, std::uint32_t count) {
    if (count > capacity_) reserve(count, kCache_);
    if (count > 0) glCopyNamedBufferSubData(source, buffer_.id(), 0, 0, GLsizeiptr(count) * kValBytes);
}

void ValChunkBuffer::bindChunk(std::uint32_t chunk) const {
    const GLsizeiptr bytes = GLsizeiptr(kCache_) * kValBytes;
    glBindBufferRange(GL_UNIFORM_BUFFER, 0, buffer_.id(), GLintptr(chunk) * bytes, bytes);
}

std::uint32_t ValChunkBuffer::chunkCount(std::uint32_t count) const {
    return (count + std::uint32_t(kCache_) - 1) / std::uint32_t(kCache_);
}

std::uint32_t ValChunkBuffer::chunkSize(std::uint32_t chunk, std::uint32_t count) const {
    return std::min<std::uint32_t>(std::uint32_t(kCache_), count - chunk * std::uint32_t(kCache_));
}

GLint requireUniform(const gl::Program& program, const char* name, const char* shader) {
    const GLint location = program.uniformLocation(name);
    if (location < 0) throw Error(shader, std::nullopt, std::string("uniform ") + name + " not found");
    return location;
}

std::vector<std::string> variantDefines(int kCache, bool glossy, bool occlusion) {
    std::vector<std::string> defines{"K_CACHE " + std::to_string(kCache)};
    if (glossy) defines.emplace_back("GLOSSY");
    if (occlusion) defines.emplace_back("OCCLUSION");
    return defines;
}

} // namespace lightskin::gi::detail
