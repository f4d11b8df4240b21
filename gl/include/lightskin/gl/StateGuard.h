#pragma once
// Saves the OpenGL state that lightskin's GL code can change and restores it when the guard goes
// out of scope, so that a host engine that owns the context finds its state as it left it. What is
// covered and what is not (and why): docs/PLUGIN.md, "What the state guard saves".
//
// Needs a current GL 4.5 context for its whole life; not copyable. Costs ~200 glGet calls per
// save and the matching restores, no allocation (4 microseconds on llvmpipe: docs/BENCHMARKS.md).

#include <epoxy/gl.h>

#include <array>

namespace lightskin::gl {

class StateGuard {
public:
    static constexpr int kTextureUnits = 16;
    static constexpr int kIndexedBindings = 8;
    static constexpr int kImageUnits = 8;
    static constexpr int kTextureTargets = 8;

    StateGuard();
    ~StateGuard();
    StateGuard(const StateGuard&) = delete;
    StateGuard& operator=(const StateGuard&) = delete;

private:
    struct IndexedBuffer {
        GLint name = 0;
        GLint64 start = 0, size = 0;
    };
    struct ImageUnit {
        GLint name = 0, level = 0, layered = 0, layer = 0, access = 0, format = 0;
    };
    GLint drawFramebuffer_ = 0, readFramebuffer_ = 0, program_ = 0, vertexArray_ = 0;
    std::array<GLint, 9> genericBuffers_{};
    std::array<std::array<IndexedBuffer, kIndexedBindings>, 3> indexed_{};
    std::array<int, 3> indexedCount_{}; ///< min(kIndexedBindings, the context's maximum) per kind
    GLint activeTexture_ = 0;
    std::array<std::array<GLint, kTextureTargets>, kTextureUnits> textures_{};
    std::array<GLint, kTextureUnits> samplers_{};
    std::array<ImageUnit, kImageUnits> images_{};
    std::array<GLint, 4> viewport_{}, scissorBox_{};
    std::array<GLboolean, 9> enables_{};
    GLboolean depthMask_ = GL_TRUE;
    std::array<GLboolean, 4> colourMask_{};
    GLint depthFunc_ = 0, blendSrcRgb_ = 0, blendDstRgb_ = 0, blendSrcAlpha_ = 0, blendDstAlpha_ = 0;
    GLint blendEquationRgb_ = 0, blendEquationAlpha_ = 0, cullFaceMode_ = 0, frontFace_ = 0;
    std::array<GLint, 2> polygonMode_{};
    std::array<GLfloat, 4> blendColour_{}, clearColour_{};
    GLfloat clearDepth_ = 1.0f;
    std::array<GLint, 8> pixelStore_{};
};

} // namespace lightskin::gl
