#include <lightskin/gl/Readback.h>
#include <lightskin/gl/SelfTest.h>
#include <lightskin/gl/ShaderLibrary.h>

#include <algorithm>
#include <string>

namespace lightskin::gl {

cv::Mat renderSelfTestTriangle(int width, int height, float red) {
    const ShaderLibrary library{};
    const std::string defines[] = {"TRIANGLE_RED " + std::to_string(red)};
    Program program = library.buildProgram(
        {{GL_VERTEX_SHADER, "selftest_triangle.vert"}, {GL_FRAGMENT_SHADER, "selftest_triangle.frag"}}, defines);
    Texture target = Texture::create2D(GL_RGBA8, width, height);
    Framebuffer framebuffer = Framebuffer::create();
    framebuffer.attach(GL_COLOR_ATTACHMENT0, target);
    framebuffer.checkComplete("self-test framebuffer");
    VertexArray vertexArray = VertexArray::create();

    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer.id());
    glViewport(0, 0, width, height);
    const float black[4] = {0.f, 0.f, 0.f, 1.f};
    glClearNamedFramebufferfv(framebuffer.id(), GL_COLOR, 0, black);
    program.use();
    glBindVertexArray(vertexArray.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindVertexArray(0);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);

    cv::Mat image;
    readTextureRgba8Into(target, image);
    return image;
}

std::uint32_t sumOnGpu(std::span<const std::uint32_t> values) {
    const ShaderLibrary library{};
    Program program = library.buildProgram({{GL_COMPUTE_SHADER, "selftest_sum.comp"}});
    const auto bytes = GLsizeiptr(std::max<std::size_t>(values.size_bytes(), 4));
    Buffer input = Buffer::create(bytes, nullptr);
    if (!values.empty()) input.upload(0, GLsizeiptr(values.size_bytes()), values.data());
    const std::uint32_t zero = 0;
    Buffer total = Buffer::create(sizeof zero, &zero);
    program.use();
    glUniform1ui(program.uniformLocation("count"), GLuint(values.size()));
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, input.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, total.id());
    glDispatchCompute(GLuint((values.size() + 63) / 64), 1, 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    std::uint32_t result = 0;
    glGetNamedBufferSubData(total.id(), 0, sizeof result, &result);
    return result;
}

} // namespace lightskin::gl
