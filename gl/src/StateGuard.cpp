#include <lightskin/gl/StateGuard.h>

#include <algorithm>
#include <cstddef>

namespace lightskin::gl {

namespace {

// Generic binding points: the query and the target to rebind it to (same order as genericBuffers_).
constexpr std::array<std::array<GLenum, 2>, 9> kGenericBuffers = {{
    {GL_ARRAY_BUFFER_BINDING, GL_ARRAY_BUFFER},
    {GL_PIXEL_PACK_BUFFER_BINDING, GL_PIXEL_PACK_BUFFER},
    {GL_PIXEL_UNPACK_BUFFER_BINDING, GL_PIXEL_UNPACK_BUFFER},
    {GL_SHADER_STORAGE_BUFFER_BINDING, GL_SHADER_STORAGE_BUFFER},
    {GL_UNIFORM_BUFFER_BINDING, GL_UNIFORM_BUFFER},
    {GL_ATOMIC_COUNTER_BUFFER_BINDING, GL_ATOMIC_COUNTER_BUFFER},
    {GL_COPY_READ_BUFFER_BINDING, GL_COPY_READ_BUFFER},
    {GL_COPY_WRITE_BUFFER_BINDING, GL_COPY_WRITE_BUFFER},
    {GL_DRAW_INDIRECT_BUFFER_BINDING, GL_DRAW_INDIRECT_BUFFER},
}};

// Indexed binding points: target, name query, start query, size query.
constexpr std::array<std::array<GLenum, 4>, 3> kIndexed = {{
    {GL_SHADER_STORAGE_BUFFER, GL_SHADER_STORAGE_BUFFER_BINDING, GL_SHADER_STORAGE_BUFFER_START,
     GL_SHADER_STORAGE_BUFFER_SIZE},
    {GL_UNIFORM_BUFFER, GL_UNIFORM_BUFFER_BINDING, GL_UNIFORM_BUFFER_START, GL_UNIFORM_BUFFER_SIZE},
    {GL_ATOMIC_COUNTER_BUFFER, GL_ATOMIC_COUNTER_BUFFER_BINDING, GL_ATOMIC_COUNTER_BUFFER_START,
     GL_ATOMIC_COUNTER_BUFFER_SIZE},
}};

constexpr std::array<std::array<GLenum, 2>, StateGuard::kTextureTargets> kTargetQueries = {{
    {GL_TEXTURE_BINDING_1D, GL_TEXTURE_1D},
    {GL_TEXTURE_BINDING_2D, GL_TEXTURE_2D},
    {GL_TEXTURE_BINDING_3D, GL_TEXTURE_3D},
    {GL_TEXTURE_BINDING_2D_ARRAY, GL_TEXTURE_2D_ARRAY},
    {GL_TEXTURE_BINDING_CUBE_MAP, GL_TEXTURE_CUBE_MAP},
    {GL_TEXTURE_BINDING_CUBE_MAP_ARRAY, GL_TEXTURE_CUBE_MAP_ARRAY},
    {GL_TEXTURE_BINDING_RECTANGLE, GL_TEXTURE_RECTANGLE},
    {GL_TEXTURE_BINDING_BUFFER, GL_TEXTURE_BUFFER},
}};

constexpr std::array<GLenum, 9> kEnables = {GL_BLEND,
                                            GL_DEPTH_TEST,
                                            GL_CULL_FACE,
                                            GL_SCISSOR_TEST,
                                            GL_STENCIL_TEST,
                                            GL_POLYGON_OFFSET_FILL,
                                            GL_FRAMEBUFFER_SRGB,
                                            GL_RASTERIZER_DISCARD,
                                            GL_PROGRAM_POINT_SIZE};

constexpr std::array<GLenum, 8> kPixelStore = {GL_PACK_ALIGNMENT,   GL_PACK_ROW_LENGTH,   GL_PACK_SKIP_ROWS,
                                               GL_PACK_SKIP_PIXELS, GL_UNPACK_ALIGNMENT,  GL_UNPACK_ROW_LENGTH,
                                               GL_UNPACK_SKIP_ROWS, GL_UNPACK_SKIP_PIXELS};

GLuint asName(GLint value) { return static_cast<GLuint>(value); }
GLenum asEnum(GLint value) { return static_cast<GLenum>(value); }

} // namespace

StateGuard::StateGuard() {
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &drawFramebuffer_);
    glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &readFramebuffer_);
    glGetIntegerv(GL_CURRENT_PROGRAM, &program_);
    glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &vertexArray_);
    for (std::size_t i = 0; i < kGenericBuffers.size(); ++i) glGetIntegerv(kGenericBuffers[i][0], &genericBuffers_[i]);
    // GL 4.5 guarantees 8 SSBO and 36 UBO binding points but only 1 atomic-counter one: ask.
    constexpr std::array<GLenum, 3> kMaxima = {GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS, GL_MAX_UNIFORM_BUFFER_BINDINGS,
                                               GL_MAX_ATOMIC_COUNTER_BUFFER_BINDINGS};
    for (std::size_t t = 0; t < kIndexed.size(); ++t) {
        GLint maximum = 0;
        glGetIntegerv(kMaxima[t], &maximum);
        indexedCount_[t] = std::min(kIndexedBindings, int(maximum));
    }
    for (std::size_t t = 0; t < kIndexed.size(); ++t)
        for (std::size_t i = 0; i < std::size_t(indexedCount_[t]); ++i) {
            IndexedBuffer& b = indexed_[t][i];
            glGetIntegeri_v(kIndexed[t][1], GLuint(i), &b.name);
            glGetInteger64i_v(kIndexed[t][2], GLuint(i), &b.start);
            glGetInteger64i_v(kIndexed[t][3], GLuint(i), &b.size);
        }
    glGetIntegerv(GL_ACTIVE_TEXTURE, &activeTexture_);
    for (int u = 0; u < kTextureUnits; ++u) {
        glActiveTexture(GLenum(GL_TEXTURE0 + u));
        for (std::size_t t = 0; t < kTargetQueries.size(); ++t)
            glGetIntegerv(kTargetQueries[t][0], &textures_[std::size_t(u)][t]);
        glGetIntegerv(GL_SAMPLER_BINDING, &samplers_[std::size_t(u)]);
    }
    glActiveTexture(asEnum(activeTexture_));
    for (std::size_t i = 0; i < kImageUnits; ++i) {
        ImageUnit& m = images_[i];
        const GLuint index = GLuint(i);
        glGetIntegeri_v(GL_IMAGE_BINDING_NAME, index, &m.name);
        glGetIntegeri_v(GL_IMAGE_BINDING_LEVEL, index, &m.level);
        glGetIntegeri_v(GL_IMAGE_BINDING_LAYERED, index, &m.layered);
        glGetIntegeri_v(GL_IMAGE_BINDING_LAYER, index, &m.layer);
        glGetIntegeri_v(GL_IMAGE_BINDING_ACCESS, index, &m.access);
        glGetIntegeri_v(GL_IMAGE_BINDING_FORMAT, index, &m.format);
    }
    glGetIntegerv(GL_VIEWPORT, viewport_.data());
    glGetIntegerv(GL_SCISSOR_BOX, scissorBox_.data());
    for (std::size_t i = 0; i < kEnables.size(); ++i) enables_[i] = glIsEnabled(kEnables[i]);
    glGetBooleanv(GL_DEPTH_WRITEMASK, &depthMask_);
    glGetBooleanv(GL_COLOR_WRITEMASK, colourMask_.data());
    glGetIntegerv(GL_DEPTH_FUNC, &depthFunc_);
    glGetIntegerv(GL_BLEND_SRC_RGB, &blendSrcRgb_);
    glGetIntegerv(GL_BLEND_DST_RGB, &blendDstRgb_);
    glGetIntegerv(GL_BLEND_SRC_ALPHA, &blendSrcAlpha_);
    glGetIntegerv(GL_BLEND_DST_ALPHA, &blendDstAlpha_);
    glGetIntegerv(GL_BLEND_EQUATION_RGB, &blendEquationRgb_);
    glGetIntegerv(GL_BLEND_EQUATION_ALPHA, &blendEquationAlpha_);
    glGetFloatv(GL_BLEND_COLOR, blendColour_.data());
    glGetFloatv(GL_COLOR_CLEAR_VALUE, clearColour_.data());
    glGetFloatv(GL_DEPTH_CLEAR_VALUE, &clearDepth_);
    glGetIntegerv(GL_CULL_FACE_MODE, &cullFaceMode_);
    glGetIntegerv(GL_FRONT_FACE, &frontFace_);
    glGetIntegerv(GL_POLYGON_MODE, polygonMode_.data());
    for (std::size_t i = 0; i < kPixelStore.size(); ++i) glGetIntegerv(kPixelStore[i], &pixelStore_[i]);
}

StateGuard::~StateGuard() {
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, asName(drawFramebuffer_));
    glBindFramebuffer(GL_READ_FRAMEBUFFER, asName(readFramebuffer_));
    glUseProgram(asName(program_));
    glBindVertexArray(asName(vertexArray_));
    // Indexed bindings first: glBindBufferBase/Range also set the generic binding point.
    for (std::size_t t = 0; t < kIndexed.size(); ++t)
        for (std::size_t i = 0; i < std::size_t(indexedCount_[t]); ++i) {
            const IndexedBuffer& b = indexed_[t][i];
            if (b.name != 0 && b.size > 0)
                glBindBufferRange(kIndexed[t][0], GLuint(i), asName(b.name), GLintptr(b.start), GLsizeiptr(b.size));
            else
                glBindBufferBase(kIndexed[t][0], GLuint(i), asName(b.name));
        }
    for (std::size_t i = 0; i < kGenericBuffers.size(); ++i)
        glBindBuffer(kGenericBuffers[i][1], asName(genericBuffers_[i]));
    for (int u = 0; u < kTextureUnits; ++u) {
        glActiveTexture(GLenum(GL_TEXTURE0 + u));
        for (std::size_t t = 0; t < kTargetQueries.size(); ++t)
            glBindTexture(kTargetQueries[t][1], asName(textures_[std::size_t(u)][t]));
        glBindSampler(GLuint(u), asName(samplers_[std::size_t(u)]));
    }
    glActiveTexture(asEnum(activeTexture_));
    for (std::size_t i = 0; i < kImageUnits; ++i) {
        const ImageUnit& m = images_[i];
        // An unbound unit reports format 0 on some drivers; any valid format is accepted with name 0.
        glBindImageTexture(GLuint(i), asName(m.name), m.level, GLboolean(m.layered), m.layer,
                           m.access != 0 ? asEnum(m.access) : GLenum(GL_READ_ONLY),
                           m.format != 0 ? asEnum(m.format) : GLenum(GL_R8));
    }
    glViewport(viewport_[0], viewport_[1], viewport_[2], viewport_[3]);
    glScissor(scissorBox_[0], scissorBox_[1], scissorBox_[2], scissorBox_[3]);
    for (std::size_t i = 0; i < kEnables.size(); ++i) (enables_[i] ? glEnable : glDisable)(kEnables[i]);
    glDepthMask(depthMask_);
    glColorMask(colourMask_[0], colourMask_[1], colourMask_[2], colourMask_[3]);
    glDepthFunc(asEnum(depthFunc_));
    glBlendFuncSeparate(asEnum(blendSrcRgb_), asEnum(blendDstRgb_), asEnum(blendSrcAlpha_), asEnum(blendDstAlpha_));
    glBlendEquationSeparate(asEnum(blendEquationRgb_), asEnum(blendEquationAlpha_));
    glBlendColor(blendColour_[0], blendColour_[1], blendColour_[2], blendColour_[3]);
    glClearColor(clearColour_[0], clearColour_[1], clearColour_[2], clearColour_[3]);
    glClearDepthf(clearDepth_);
    glCullFace(asEnum(cullFaceMode_));
    glFrontFace(asEnum(frontFace_));
    // Core profile: front and back share one mode (GL_POLYGON_MODE reports it twice).
    glPolygonMode(GL_FRONT_AND_BACK, asEnum(polygonMode_[0]));
    for (std::size_t i = 0; i < kPixelStore.size(); ++i) glPixelStorei(kPixelStore[i], pixelStore_[i]);
}

} // namespace lightskin::gl
