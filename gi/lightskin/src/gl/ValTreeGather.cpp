#include "ValTreeGather.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>

#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <chrono>
#include <string>

namespace lightskin::gi::detail {

namespace {
constexpr std::uint32_t kStackSize = std::uint32_t(kValTreeMaxDepth) + 1; // gather_tree.comp's kStackSize
}

void ValTreeGather::buildPrograms(const gl::ShaderLibrary& library, bool nearField) {
    for (int g = 0; g < 2; ++g)
        for (int o = 0; o < 2; ++o)
            programs_[g][o] = library.buildProgram({{GL_COMPUTE_SHADER, "gather_tree.comp"}},
                                                   variantDefines(16, g != 0, o != 0, nearField));
    quadtree_ = GpuValQuadtree::create();
}

void ValTreeGather::reserve(std::uint32_t valCount, std::uint32_t pointCount) {
    const std::uint32_t nodes = std::max(1u, 2u * valCount);
    if (!stats_.quadtree && nodes > nodeCapacity_) {
        if (nodeCapacity_ > 0) log::info("lightskin: VAL tree buffer grows to " + std::to_string(nodes) + " nodes");
        nodeCapacity_ = nodes;
        nodes_ = gl::Buffer::create(GLsizeiptr(nodes) * GLsizeiptr(sizeof(ValCluster)));
    }
    if (pointCount > pointCapacity_) {
        pointCapacity_ = pointCount;
        const GLsizeiptr entries = GLsizeiptr(pointCount) * kStackSize;
        walk_ = gl::Buffer::create(GLsizeiptr(pointCount) * 2 * 16);
        stackD_ = gl::Buffer::create(entries * 16);
        stackS_ = gl::Buffer::create(entries * 16);
        stackNode_ = gl::Buffer::create(entries * 4);
        counters_ = gl::Buffer::create(4 * 4);
    }
}

void ValTreeGather::run(std::uint32_t valBuffer, std::uint32_t count, std::uint32_t keyBuffer, std::uint32_t keyWidth,
                        std::uint32_t keyCount, std::uint32_t pointCount, std::uint32_t pointPosition,
                        std::uint32_t pointNormal, const std::array<std::uint32_t, 5>& targets, const glm::vec3& eye,
                        float c, bool glossy, bool moments, float threshold, int stepsPerDispatch) {
    LIGHTSKIN_ASSERT(threshold > 0.0f, "lightskin::gi::detail::ValTreeGather::run(): threshold must be > 0");
    stats_ = ValTreeGatherStats{};
    const auto start = std::chrono::steady_clock::now();
    stats_.quadtree = keyBuffer != 0 && keyWidth > 0;
    std::uint32_t nodeBuffer = 0;
    if (stats_.quadtree) {
        stats_.nodes = quadtree_.build(ValSetView{valBuffer, count, 0, keyBuffer, keyCount, keyWidth});
        nodeBuffer = quadtree_.nodeBuffer();
    } else {
        vals_.resize(count);
        if (count > 0) glGetNamedBufferSubData(valBuffer, 0, GLsizeiptr(count) * GLsizeiptr(kValBytes), vals_.data());
        buildValTreeInto(std::span<const VirtualAreaLight>(vals_), tree_);
        stats_.nodes = std::uint32_t(tree_.nodes.size());
    }
    reserve(count, pointCount);
    if (!stats_.quadtree) {
        if (!tree_.nodes.empty())
            nodes_.upload(0, GLsizeiptr(tree_.nodes.size() * sizeof(ValCluster)), tree_.nodes.data());
        nodeBuffer = nodes_.id();
    }
    stats_.buildMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (stats_.nodes == 0 || pointCount == 0) return;

    const gl::Program& p = programs_[glossy ? 1 : 0][moments ? 1 : 0];
    p.use();
    glUniform1i(p.uniformLocation("uPointCount"), int(pointCount));
    glUniform3fv(p.uniformLocation("uEye"), 1, glm::value_ptr(eye));
    glUniform1f(p.uniformLocation("uC"), c);
    glUniform1f(p.uniformLocation("uThreshold"), threshold);
    // each thread loops at most `steps` times per dispatch: far below llvmpipe's ~65k iterations
    const std::uint32_t steps = std::uint32_t(std::clamp(stepsPerDispatch, 64, 32768));
    glUniform1ui(p.uniformLocation("uSteps"), steps);
    glBindTextureUnit(8, pointPosition);
    glBindTextureUnit(9, pointNormal);
    for (std::size_t i = 0; i < targets.size(); ++i)
        glBindImageTexture(GLuint(i), targets[i], 0, GL_FALSE, 0, GL_READ_WRITE, GL_RGBA32F);
    glBindBufferRange(GL_SHADER_STORAGE_BUFFER, 0, valBuffer, 0, GLsizeiptr(count) * GLsizeiptr(kValBytes));
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, nodeBuffer);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, walk_.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, stackD_.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, stackS_.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5, stackNode_.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 6, counters_.id());
    // every node is visited at most once per point: this many dispatches always finish the walk
    const std::uint32_t maxDispatches = stats_.nodes / steps + 2;
    for (std::uint32_t d = 0; d < maxDispatches; ++d) {
        std::uint32_t counters[4] = {0, 0, 0, 0};
        counters_.upload(0, sizeof counters, counters);
        glUniform1i(p.uniformLocation("uFirstDispatch"), d == 0 ? 1 : 0);
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT |
                        GL_BUFFER_UPDATE_BARRIER_BIT);
        glDispatchCompute((pointCount + 63) / 64, 1, 1);
        ++stats_.dispatches;
        glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
        glGetNamedBufferSubData(counters_.id(), 0, sizeof counters, counters);
        stats_.visited += counters[1];
        stats_.taken += counters[2];
        if (counters[0] == 0) break;
    }
    glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
}

} // namespace lightskin::gi::detail
