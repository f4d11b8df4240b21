// GpuValQuadtree (GpuValQuadtree.h): the passes of gi/lightskin/shaders/val_tree_build.comp, the image levels
// paired as in ValTree.cpp's buildValQuadtreeInto.
#include "common/src/LightsShaders.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/gi/lightskin/GpuValQuadtree.h>
#include <lightskin/gl/ShaderLibrary.h>

#include <epoxy/gl.h>

#include <string>

namespace lightskin::gi {

namespace {
constexpr std::uint32_t kEmpty = 0xFFFFFFFFu;
constexpr std::uint32_t kGroup = 64; // val_tree_build.comp's local_size_x
constexpr GLsizeiptr kCellBytes = 8; // uvec2

std::uint32_t groups(std::uint64_t invocations) { return std::uint32_t((invocations + kGroup - 1) / kGroup); }

// Grows `buffer` to hold `needed` elements of `bytes` (never shrinks).
void grow(gl::Buffer& buffer, std::uint32_t& capacity, std::uint64_t needed, GLsizeiptr bytes, const char* what) {
    if (needed <= capacity && buffer.id() != 0) return;
    if (capacity > 0)
        log::info(std::string("lightskin: GPU VAL quadtree ") + what + " grows to " + std::to_string(needed));
    capacity = std::uint32_t(needed);
    buffer = gl::Buffer::create(GLsizeiptr(needed) * bytes);
}
} // namespace

GpuValQuadtree GpuValQuadtree::create() {
    GpuValQuadtree t;
    const gl::ShaderLibrary library{embeddedShaders()};
    const std::string leaves[] = {"PASS_LEAVES"}, level[] = {"PASS_LEVEL"}, root[] = {"PASS_ROOT"};
    t.leaves_ = library.buildProgram({{GL_COMPUTE_SHADER, "val_tree_build.comp"}}, leaves);
    t.level_ = library.buildProgram({{GL_COMPUTE_SHADER, "val_tree_build.comp"}}, level);
    t.root_ = library.buildProgram({{GL_COMPUTE_SHADER, "val_tree_build.comp"}}, root);
    t.info_ = gl::Buffer::create(4 * 4);
    return t;
}

std::uint32_t GpuValQuadtree::build(const ValSetView& vals) {
    LIGHTSKIN_ASSERT(leaves_.id() != 0, "lightskin::gi::GpuValQuadtree::build(): not created");
    LIGHTSKIN_ASSERT(vals.keys != 0 && vals.keyWidth > 0 && vals.keyCount % vals.keyWidth == 0,
                     "lightskin::gi::GpuValQuadtree::build(): needs pixel keys of an image (ValSetView::keyWidth)");
    const std::uint32_t count = vals.count;
    LIGHTSKIN_ASSERT(count < 0x7FFFFFFFu, "lightskin::gi::GpuValQuadtree::build(): too many VALs");
    const std::uint32_t width = vals.keyWidth, height = vals.keyCount / vals.keyWidth;
    slots_ = 2 * count + 1;
    grow(nodes_, nodeCapacity_, slots_, GLsizeiptr(sizeof(ValCluster)), "node buffer");
    const std::uint32_t info[4] = {kEmpty, 0, 0, kEmpty};
    info_.upload(0, sizeof info, info);
    if (count == 0) return 0;

    // level 0 (the image) in cells_[0]; the first pairing halves u, so cells_[1] needs ceil(w / 2) h
    const std::uint64_t pixels = std::uint64_t(width) * height;
    LIGHTSKIN_ASSERT(pixels < kEmpty, "lightskin::gi::GpuValQuadtree::build(): image too large for uint keys");
    grow(cells_[0], cellCapacity_[0], pixels, kCellBytes, "cell buffer");
    grow(cells_[1], cellCapacity_[1], (std::uint64_t(width) + 1) / 2 * height, kCellBytes, "cell buffer");
    const std::uint32_t empty[2] = {kEmpty, kEmpty};
    glClearNamedBufferSubData(cells_[0].id(), GL_RG32UI, 0, GLsizeiptr(pixels) * kCellBytes, GL_RG_INTEGER,
                              GL_UNSIGNED_INT, empty);

    glBindBufferRange(GL_SHADER_STORAGE_BUFFER, 0, vals.buffer, 0,
                      GLsizeiptr(count) * GLsizeiptr(sizeof(VirtualAreaLight)));
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, nodes_.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, info_.id());
    glBindBufferRange(GL_SHADER_STORAGE_BUFFER, 3, vals.keys, 0, GLsizeiptr(count) * 4);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, cells_[0].id());
    leaves_.use();
    glUniform1ui(leaves_.uniformLocation("uCount"), count);
    glUniform1ui(leaves_.uniformLocation("uPixels"), std::uint32_t(pixels));
    glUniform1ui(leaves_.uniformLocation("uLeafBase"), count + 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
    glDispatchCompute(groups(count), 1, 1);

    level_.use();
    const GLint inSize = level_.uniformLocation("uInSize"), outSize = level_.uniformLocation("uOutSize");
    const GLint pairULocation = level_.uniformLocation("uPairU");
    std::uint32_t w = width, h = height;
    int current = 0;
    bool alongU = true;
    int levels = 1;
    while (w > 1 || h > 1) {
        // as buildValQuadtreeInto: pair along u and v in turn; a side of 1 stops pairing
        const bool pairU = (alongU && w > 1) || h == 1;
        alongU = !pairU;
        const std::uint32_t nw = pairU ? (w + 1) / 2 : w, nh = pairU ? h : (h + 1) / 2;
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, cells_[current].id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5, cells_[1 - current].id());
        glUniform2ui(inSize, w, h);
        glUniform2ui(outSize, nw, nh);
        glUniform1i(pairULocation, pairU ? 1 : 0);
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
        glDispatchCompute(groups(std::uint64_t(nw) * nh), 1, 1);
        w = nw;
        h = nh;
        current = 1 - current;
        ++levels;
    }
    // a node's depth is at most its level count: the walk's fixed stack always suffices
    LIGHTSKIN_ASSERT(levels <= kValTreeMaxDepth, "lightskin::gi::GpuValQuadtree::build(): image too large");
    root_.use();
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, cells_[current].id());
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    glDispatchCompute(1, 1, 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);

    std::uint32_t result[4];
    glGetNamedBufferSubData(info_.id(), 0, sizeof result, result);
    if (result[2] > 0)
        throw Error("VAL keys", std::nullopt,
                    std::to_string(result[2]) + " VAL(s) with a pixel key outside the " + std::to_string(width) + "x" +
                        std::to_string(height) + " image or on a pixel already taken, the first: VAL " +
                        std::to_string(result[3]));
    return result[0] == kEmpty ? 0u : 2 * result[1] - 1;
}

void GpuValQuadtree::readNodes(std::vector<ValCluster>& out) const {
    out.resize(slots_);
    if (slots_ == 0) return;
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glGetNamedBufferSubData(nodes_.id(), 0, GLsizeiptr(slots_) * GLsizeiptr(sizeof(ValCluster)), out.data());
}

} // namespace lightskin::gi
