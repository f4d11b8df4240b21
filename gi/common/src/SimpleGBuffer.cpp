#include "GatherShaders.h"

#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gl/ShaderLibrary.h>

#include <glm/gtc/type_ptr.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

namespace lightskin::gi {

UploadedMesh UploadedMesh::create(const TriangleMesh& mesh) {
    UploadedMesh m;
    m.vertexArray_ = gl::VertexArray::create();
    const GLuint vao = m.vertexArray_.id();
    m.positions_ = gl::Buffer::create(GLsizeiptr(std::max<std::size_t>(1, mesh.positions.size()) * sizeof(glm::vec3)),
                                      mesh.positions.data(), 0);
    m.normals_ = gl::Buffer::create(GLsizeiptr(std::max<std::size_t>(1, mesh.normals.size()) * sizeof(glm::vec3)),
                                    mesh.normals.data(), 0);
    m.indices_ = gl::Buffer::create(GLsizeiptr(std::max<std::size_t>(1, mesh.indices.size()) * sizeof(std::uint32_t)),
                                    mesh.indices.data(), 0);
    glVertexArrayVertexBuffer(vao, 0, m.positions_.id(), 0, sizeof(glm::vec3));
    glVertexArrayVertexBuffer(vao, 1, m.normals_.id(), 0, sizeof(glm::vec3));
    for (GLuint a = 0; a < 2; ++a) {
        glEnableVertexArrayAttrib(vao, a);
        glVertexArrayAttribFormat(vao, a, 3, GL_FLOAT, GL_FALSE, 0);
        glVertexArrayAttribBinding(vao, a, a);
    }
    if (!mesh.texcoords.empty()) { // attribute 2 when present (multi-scale PRT's small-scale maps read it)
        m.texcoords_ =
            gl::Buffer::create(GLsizeiptr(mesh.texcoords.size() * sizeof(glm::vec2)), mesh.texcoords.data(), 0);
        glVertexArrayVertexBuffer(vao, 2, m.texcoords_.id(), 0, sizeof(glm::vec2));
        glEnableVertexArrayAttrib(vao, 2);
        glVertexArrayAttribFormat(vao, 2, 2, GL_FLOAT, GL_FALSE, 0);
        glVertexArrayAttribBinding(vao, 2, 2);
    }
    glVertexArrayElementBuffer(vao, m.indices_.id());
    m.view_ = GpuMeshView{vao, std::uint32_t(mesh.indices.size()), std::uint32_t(mesh.vertexCount())};
    return m;
}

SimpleGBuffer SimpleGBuffer::create(int width, int height) {
    SimpleGBuffer g;
    g.width_ = width;
    g.height_ = height;
    g.position_ = gl::Texture::create2D(GL_RGBA32F, width, height);
    g.normal_ = gl::Texture::create2D(GL_RGBA32F, width, height);
    g.albedo_ = gl::Texture::create2D(GL_RGBA32F, width, height);
    g.specular_ = gl::Texture::create2D(GL_RGBA32F, width, height);
    g.depth_ = gl::Texture::create2D(GL_DEPTH_COMPONENT32F, width, height);
    g.framebuffer_ = gl::Framebuffer::create();
    g.framebuffer_.attach(GL_COLOR_ATTACHMENT0, g.position_);
    g.framebuffer_.attach(GL_COLOR_ATTACHMENT1, g.normal_);
    g.framebuffer_.attach(GL_COLOR_ATTACHMENT2, g.albedo_);
    g.framebuffer_.attach(GL_COLOR_ATTACHMENT3, g.specular_);
    g.framebuffer_.attach(GL_DEPTH_ATTACHMENT, g.depth_);
    const GLenum buffers[4] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2, GL_COLOR_ATTACHMENT3};
    glNamedFramebufferDrawBuffers(g.framebuffer_.id(), 4, buffers);
    g.framebuffer_.checkComplete("SimpleGBuffer");
    const gl::ShaderLibrary library{embeddedShaders()};
    g.program_ =
        library.buildProgram({{GL_VERTEX_SHADER, "gather_gbuffer.vert"}, {GL_FRAGMENT_SHADER, "gather_gbuffer.frag"}});
    return g;
}

void SimpleGBuffer::render(std::span<const MeshInstance> instances, const glm::mat4& clip_T_world) {
    const float zeros[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    for (int i = 0; i < 4; ++i) glClearNamedFramebufferfv(framebuffer_.id(), GL_COLOR, i, zeros);
    const float one = 1.0f;
    glClearNamedFramebufferfv(framebuffer_.id(), GL_DEPTH, 0, &one);
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
    glViewport(0, 0, width_, height_);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
    glDisable(GL_CULL_FACE);
    program_.use();
    glUniformMatrix4fv(program_.uniformLocation("uClipFromWorld"), 1, GL_FALSE, glm::value_ptr(clip_T_world));
    for (const MeshInstance& instance : instances) {
        const glm::mat3 normalMatrix = glm::transpose(glm::inverse(glm::mat3(instance.world_T_model)));
        glUniformMatrix4fv(program_.uniformLocation("uWorldFromModel"), 1, GL_FALSE,
                           glm::value_ptr(instance.world_T_model));
        glUniformMatrix3fv(program_.uniformLocation("uNormalFromModel"), 1, GL_FALSE, glm::value_ptr(normalMatrix));
        glUniform3fv(program_.uniformLocation("uAlbedo"), 1, glm::value_ptr(instance.material.diffuseAlbedo));
        const glm::vec4 specular(instance.material.specularAlbedo, instance.material.specularExponent);
        glUniform4fv(program_.uniformLocation("uSpecular"), 1, glm::value_ptr(specular));
        setFrontFaceFor(instance.world_T_model); // the back-face flag, as the renderer
        glBindVertexArray(instance.gpu.vertexArray);
        glDrawElements(GL_TRIANGLES, GLsizei(instance.gpu.indexCount), GL_UNSIGNED_INT, nullptr);
    }
    glFrontFace(GL_CCW);
    glBindVertexArray(0);
    glDisable(GL_DEPTH_TEST);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

GBufferView SimpleGBuffer::view() const noexcept {
    return GBufferView{position_.id(), normal_.id(), albedo_.id(), specular_.id(), depth_.id(), width_, height_};
}

} // namespace lightskin::gi
