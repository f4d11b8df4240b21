#include "GatherShaders.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>

#include <glm/geometric.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/matrix.hpp>

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

std::vector<std::string> variantDefines(int kCache, bool glossy, bool occlusion, bool nearField) {
    std::vector<std::string> defines{"K_CACHE " + std::to_string(kCache)};
    if (!nearField) defines.emplace_back("LS_NEAR_FIELD 0");
    if (glossy) defines.emplace_back("GLOSSY");
    if (occlusion) defines.emplace_back("OCCLUSION");
    return defines;
}

bool convexForOcclusion(const SparsePointSet& set) {
    const auto& points = set.points;
    float extent = 0.0f;
    for (const SparsePoint& p : points) extent = std::max(extent, glm::length(p.position - points.front().position));
    const float tolerance = 1e-5f * extent;
    for (const SparsePoint& a : points)
        for (const SparsePoint& b : points)
            if (glm::dot(a.normal, b.position - a.position) > tolerance) return false;
    return true;
}

void shadeVertexVpls(const gl::Program& shade, std::uint32_t vertexVpls, std::span<const std::uint32_t> vertexOffsets,
                     std::span<const MeshInstance> instances, const GBufferView& gbuffer, const ViewParameters& view,
                     float positionTolerance, bool glossy, std::uint32_t targetTexture,
                     const gl::Framebuffer& framebuffer) {
    const float zeros[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    glNamedFramebufferTexture(framebuffer.id(), GL_COLOR_ATTACHMENT0, targetTexture, 0);
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer.id());
    glClearNamedFramebufferfv(framebuffer.id(), GL_COLOR, 0, zeros);
    glViewport(0, 0, gbuffer.width, gbuffer.height);
    shade.use();
    glUniformMatrix4fv(shade.uniformLocation("uClipFromWorld"), 1, GL_FALSE, glm::value_ptr(view.clip_T_world));
    glUniform3fv(shade.uniformLocation("uEye"), 1, glm::value_ptr(view.cameraPositionWorld));
    glUniform1f(shade.uniformLocation("uPositionTolerance"), positionTolerance);
    glUniform1i(shade.uniformLocation("uGlossy"), glossy ? 1 : 0);
    glBindTextureUnit(0, gbuffer.worldPosition);
    glBindTextureUnit(1, gbuffer.worldNormal);
    glBindTextureUnit(2, gbuffer.diffuseAlbedo);
    glBindTextureUnit(3, gbuffer.specular);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, vertexVpls);
    for (std::size_t m = 0; m < instances.size(); ++m) {
        glUniformMatrix4fv(shade.uniformLocation("uWorldFromModel"), 1, GL_FALSE,
                           glm::value_ptr(instances[m].world_T_model));
        glUniform1ui(shade.uniformLocation("uFirstVertex"), vertexOffsets[m]);
        setFrontFaceFor(instances[m].world_T_model); // gather_shade.frag keeps front-facing fragments only
        glBindVertexArray(instances[m].gpu.vertexArray);
        glDrawElements(GL_TRIANGLES, GLsizei(instances[m].gpu.indexCount), GL_UNSIGNED_INT, nullptr);
    }
    glFrontFace(GL_CCW);
    glBindVertexArray(0);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

} // namespace lightskin::gi::detail
