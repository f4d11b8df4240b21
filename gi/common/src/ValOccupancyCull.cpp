#include "LightsShaders.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/common/ValOccupancyCull.h>
#include <lightskin/gl/ShaderLibrary.h>

#include <epoxy/gl.h>
#include <glm/gtc/type_ptr.hpp>

#include <cmath>
#include <string>

namespace lightskin::gi {

ValOccupancyCull ValOccupancyCull::create(int width, int height) {
    if (width < 1 || height < 1 || width > 16384 || height > 16384)
        throw Error("ValOccupancyCull", std::nullopt,
                    "size " + std::to_string(width) + "x" + std::to_string(height) + " out of range");
    ValOccupancyCull c;
    c.width_ = width;
    c.height_ = height;
    const gl::ShaderLibrary library{embeddedShaders()};
    c.range_ = library.buildProgram(
        {{GL_VERTEX_SHADER, "val_occupancy_range.vert"}, {GL_FRAGMENT_SHADER, "val_occupancy_range.frag"}});
    c.cull_ = library.buildProgram({{GL_COMPUTE_SHADER, "val_occupancy_cull.comp"}});
    c.rangeTexture_ = gl::Texture::create2D(GL_RG32F, width, height);
    c.framebuffer_ = gl::Framebuffer::create();
    c.framebuffer_.attach(GL_COLOR_ATTACHMENT0, c.rangeTexture_);
    c.counter_ = gl::Buffer::create(sizeof(std::uint32_t));
    return c;
}

void ValOccupancyCull::apply(const ValSetView& vals, std::span<const MeshInstance> instances,
                             const glm::mat4& clip_T_world, const glm::mat4& camera_T_world) {
    LIGHTSKIN_ASSERT(range_, "lightskin::gi::ValOccupancyCull::apply(): used before create()");
    const std::uint32_t zero = 0;
    glClearNamedBufferData(counter_.id(), GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, &zero);
    if (vals.count == 0 || instances.empty()) return;
    LIGHTSKIN_ASSERT(vals.keys != 0 && vals.keyCount == std::uint32_t(width_) * std::uint32_t(height_),
                     "lightskin::gi::ValOccupancyCull::apply(): the VALs need depth-pixel keys of this size");

    renderRange(instances, clip_T_world, camera_T_world);

    // Pass 2: cull.
    cull_.use();
    glUniform1ui(cull_.uniformLocation("uCount"), vals.count);
    glUniform2i(cull_.uniformLocation("uSize"), width_, height_);
    glUniformMatrix4fv(cull_.uniformLocation("uCameraFromWorld"), 1, GL_FALSE, glm::value_ptr(camera_T_world));
    glBindTextureUnit(0, rangeTexture_.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, vals.buffer);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, vals.keys);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, counter_.id());
    glDispatchCompute((vals.count + 63u) / 64u, 1, 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_UNIFORM_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
}

void ValOccupancyCull::renderRange(std::span<const MeshInstance> instances, const glm::mat4& clip_T_world,
                                   const glm::mat4& camera_T_world) {
    // Pass 1: depth range of the virtual content per pixel (MIN blending of (z, -z), no depth test, no culling).
    const float empty[4] = {1.0e30f, 1.0e30f, 0.0f, 0.0f};
    glClearNamedFramebufferfv(framebuffer_.id(), GL_COLOR, 0, empty);
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
    glViewport(0, 0, width_, height_);
    const GLboolean depthTest = glIsEnabled(GL_DEPTH_TEST), cullFace = glIsEnabled(GL_CULL_FACE),
                    blend = glIsEnabled(GL_BLEND);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glEnable(GL_BLEND);
    glBlendEquation(GL_MIN);
    range_.use();
    glUniformMatrix4fv(range_.uniformLocation("uClipFromWorld"), 1, GL_FALSE, glm::value_ptr(clip_T_world));
    glUniformMatrix4fv(range_.uniformLocation("uCameraFromWorld"), 1, GL_FALSE, glm::value_ptr(camera_T_world));
    for (const MeshInstance& m : instances) {
        glUniformMatrix4fv(range_.uniformLocation("uWorldFromModel"), 1, GL_FALSE, glm::value_ptr(m.world_T_model));
        glBindVertexArray(m.gpu.vertexArray);
        glDrawElements(GL_TRIANGLES, GLsizei(m.gpu.indexCount), GL_UNSIGNED_INT, nullptr);
    }
    glBindVertexArray(0);
    glBlendEquation(GL_FUNC_ADD);
    if (!blend) glDisable(GL_BLEND);
    if (cullFace) glEnable(GL_CULL_FACE);
    if (depthTest) glEnable(GL_DEPTH_TEST);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT);
}

std::uint32_t ValOccupancyCull::applyOnCpu(std::span<VirtualAreaLight> vals, std::span<const std::uint32_t> keys,
                                           std::span<const MeshInstance> instances, const glm::mat4& clip_T_world,
                                           const glm::mat4& camera_T_world) {
    LIGHTSKIN_ASSERT(range_, "lightskin::gi::ValOccupancyCull::applyOnCpu(): used before create()");
    LIGHTSKIN_ASSERT(keys.size() == vals.size(), "lightskin::gi::ValOccupancyCull::applyOnCpu(): one key per VAL");
    if (vals.empty() || instances.empty()) return 0;
    renderRange(instances, clip_T_world, camera_T_world);
    rangeOnCpu_.resize(std::size_t(width_) * std::size_t(height_) * 2); // once: the size is fixed
    glGetTextureImage(rangeTexture_.id(), 0, GL_RG, GL_FLOAT, GLsizei(rangeOnCpu_.size() * sizeof(float)),
                      rangeOnCpu_.data());
    // val_occupancy_cull.comp, the same float operations
    constexpr float kEmpty = 1.0e30f, kPi = 3.14159265358979f;
    std::uint32_t culled = 0;
    for (std::size_t i = 0; i < vals.size(); ++i) {
        VirtualAreaLight& val = vals[i];
        if (!(val.area > 0.0f)) continue;
        const std::uint32_t key = keys[i];
        LIGHTSKIN_ASSERT(key < std::uint32_t(width_) * std::uint32_t(height_),
                         "lightskin::gi::ValOccupancyCull::applyOnCpu(): key outside the depth map");
        const std::uint32_t u = key % std::uint32_t(width_), row = key / std::uint32_t(width_);
        const std::size_t texel = (std::size_t(height_) - 1 - row) * std::size_t(width_) + u; // GL rows from the bottom
        const float front = rangeOnCpu_[2 * texel], negBack = rangeOnCpu_[2 * texel + 1];
        if (front >= kEmpty) continue;
        const float z = (camera_T_world * glm::vec4(val.position, 1.0f)).z;
        const float sigma = 0.0012f + 0.0019f * (z - 0.4f) * (z - 0.4f);
        const float radius = std::sqrt(val.area / kPi);
        if (z >= front - 3.0f * sigma && z <= -negBack + radius + 3.0f * sigma) {
            val.area = 0.0f;
            ++culled;
        }
    }
    return culled;
}

std::uint32_t ValOccupancyCull::culledCount() const {
    std::uint32_t count = 0;
    glGetNamedBufferSubData(counter_.id(), 0, sizeof count, &count);
    return count;
}

} // namespace lightskin::gi
