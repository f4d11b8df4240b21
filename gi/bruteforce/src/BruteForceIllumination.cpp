#include <lightskin/core/Error.h>
#include <lightskin/gi/bruteforce/BruteForceIllumination.h>
#include <lightskin/gl/ShaderLibrary.h>

#include "common/src/GatherShaders.h"

#include <glm/gtc/type_ptr.hpp>

namespace lightskin::gi {

struct BruteForceIllumination::Impl {
    BruteForceSettings settings;
    gl::ShaderLibrary library{embeddedShaders()};
    gl::Program program;
    GLint valCount = -1, eye = -1, c = -1;
    gl::VertexArray emptyVertexArray;
    gl::Framebuffer framebuffer;
    detail::ValChunkBuffer vals;
    gl::GpuStageTimer timer;
    std::vector<gl::StageTime> stageTimes;
};

BruteForceIllumination::BruteForceIllumination() : impl_(std::make_unique<Impl>()) {}
BruteForceIllumination::~BruteForceIllumination() = default;

std::unique_ptr<BruteForceIllumination> BruteForceIllumination::create(const BruteForceSettings& settings) {
    detail::ValChunkBuffer::validateKCache(settings.kCache, "BruteForceSettings.kCache");
    std::unique_ptr<BruteForceIllumination> technique(new BruteForceIllumination());
    Impl& impl = *technique->impl_;
    impl.settings = settings;
    impl.program = impl.library.buildProgram(
        {{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "bruteforce_gather.frag"}},
        detail::variantDefines(settings.kCache, settings.glossy, false, settings.nearFieldArea));
    impl.valCount = impl.program.uniformLocation("uValCount");
    impl.eye = impl.program.uniformLocation("uEye");
    impl.c = impl.program.uniformLocation("uC");
    impl.emptyVertexArray = gl::VertexArray::create();
    impl.framebuffer = gl::Framebuffer::create();
    impl.timer = gl::GpuStageTimer::create(2);
    impl.vals.reserve(settings.valCapacity, settings.kCache);
    return technique;
}

void BruteForceIllumination::prepare(std::span<const MeshInstance>) {}

void BruteForceIllumination::render(const ValSetView& lights, std::span<const MeshInstance>, const GBufferView& gbuffer,
                                    const ViewParameters& view, std::uint32_t targetTexture) {
    Impl& impl = *impl_;
    impl.timer.beginFrame();
    impl.timer.begin("upload");
    impl.vals.copyFrom(lights.buffer, lights.count);
    impl.timer.end();
    impl.timer.begin("brute force");
    glNamedFramebufferTexture(impl.framebuffer.id(), GL_COLOR_ATTACHMENT0, targetTexture, 0);
    const float zeros[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    glClearNamedFramebufferfv(impl.framebuffer.id(), GL_COLOR, 0, zeros);
    if (lights.count > 0) {
        glBindFramebuffer(GL_FRAMEBUFFER, impl.framebuffer.id());
        glViewport(0, 0, gbuffer.width, gbuffer.height);
        glDisable(GL_DEPTH_TEST);
        glDisable(GL_CULL_FACE);
        glEnable(GL_BLEND);
        glBlendFunc(GL_ONE, GL_ONE);
        glBlendEquation(GL_FUNC_ADD);
        glBindVertexArray(impl.emptyVertexArray.id());
        impl.program.use();
        glUniform3fv(impl.eye, 1, glm::value_ptr(view.cameraPositionWorld));
        glUniform1f(impl.c, impl.settings.cParameter);
        glBindTextureUnit(0, gbuffer.worldPosition);
        glBindTextureUnit(1, gbuffer.worldNormal);
        glBindTextureUnit(2, gbuffer.diffuseAlbedo);
        glBindTextureUnit(3, gbuffer.specular);
        const std::uint32_t chunks = impl.vals.chunkCount(lights.count);
        for (std::uint32_t c = 0; c < chunks; ++c) {
            impl.vals.bindChunk(c);
            glUniform1i(impl.valCount, int(impl.vals.chunkSize(c, lights.count)));
            glDrawArrays(GL_TRIANGLES, 0, 3);
        }
        glDisable(GL_BLEND);
        glBindVertexArray(0);
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
    }
    impl.timer.end();
    impl.timer.collect(impl.stageTimes);
}

void BruteForceIllumination::lastStageTimes(std::vector<gl::StageTime>& out) const { out = impl_->stageTimes; }

} // namespace lightskin::gi
