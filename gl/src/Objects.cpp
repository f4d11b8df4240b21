#include <lightskin/core/Error.h>
#include <lightskin/gl/Objects.h>

#include <algorithm>
#include <cstdio>
#include <string>

namespace lightskin::gl {

namespace detail {
void deleteBuffer(GLuint id) { glDeleteBuffers(1, &id); }
void deleteTexture(GLuint id) { glDeleteTextures(1, &id); }
void deleteFramebuffer(GLuint id) { glDeleteFramebuffers(1, &id); }
void deleteRenderbuffer(GLuint id) { glDeleteRenderbuffers(1, &id); }
void deleteVertexArray(GLuint id) { glDeleteVertexArrays(1, &id); }
void deleteQuery(GLuint id) { glDeleteQueries(1, &id); }
void deleteShader(GLuint id) { glDeleteShader(id); }
void deleteProgram(GLuint id) { glDeleteProgram(id); }
} // namespace detail

namespace {
/// The driver's compile or link log of a shader or program.
template <typename GetParameter, typename GetLog>
std::string infoLog(GLuint id, GetParameter getParameter, GetLog getLog) {
    GLint logLength = 0;
    getParameter(id, GL_INFO_LOG_LENGTH, &logLength);
    std::string log(std::size_t(std::max(logLength, 1)), '\0');
    getLog(id, GLsizei(log.size()), nullptr, log.data());
    return log;
}
} // namespace

Buffer Buffer::create(GLsizeiptr sizeBytes, const void* data, GLbitfield flags) {
    LIGHTSKIN_ASSERT(sizeBytes > 0, "buffer size must be positive");
    GLuint id = 0;
    glCreateBuffers(1, &id);
    glNamedBufferStorage(id, sizeBytes, data, flags);
    Buffer buffer(id);
    buffer.size_ = sizeBytes;
    return buffer;
}

void Buffer::upload(GLintptr offsetBytes, GLsizeiptr sizeBytes, const void* data) {
    LIGHTSKIN_ASSERT(offsetBytes >= 0 && offsetBytes + sizeBytes <= size_, "upload outside the buffer");
    glNamedBufferSubData(id(), offsetBytes, sizeBytes, data);
}

Texture Texture::create2D(GLenum internalFormat, GLsizei width, GLsizei height, GLsizei levels) {
    LIGHTSKIN_ASSERT(width > 0 && height > 0 && levels > 0, "texture size must be positive");
    GLuint id = 0;
    glCreateTextures(GL_TEXTURE_2D, 1, &id);
    glTextureStorage2D(id, levels, internalFormat, width, height);
    glTextureParameteri(id, GL_TEXTURE_MIN_FILTER, levels > 1 ? GL_NEAREST_MIPMAP_NEAREST : GL_NEAREST);
    glTextureParameteri(id, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTextureParameteri(id, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(id, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    return Texture(id, width, height);
}

Renderbuffer Renderbuffer::create(GLenum internalFormat, GLsizei width, GLsizei height) {
    GLuint id = 0;
    glCreateRenderbuffers(1, &id);
    glNamedRenderbufferStorage(id, internalFormat, width, height);
    return Renderbuffer(id);
}

Framebuffer Framebuffer::create() {
    GLuint id = 0;
    glCreateFramebuffers(1, &id);
    return Framebuffer(id);
}

void Framebuffer::attach(GLenum attachment, const Texture& texture, GLint level) {
    glNamedFramebufferTexture(id(), attachment, texture.id(), level);
}

void Framebuffer::attach(GLenum attachment, const Renderbuffer& renderbuffer) {
    glNamedFramebufferRenderbuffer(id(), attachment, GL_RENDERBUFFER, renderbuffer.id());
}

void Framebuffer::checkComplete(std::string_view what) const {
    const GLenum status = glCheckNamedFramebufferStatus(id(), GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE)
        throw Error(std::string(what), std::nullopt, "framebuffer incomplete (status 0x" + [&] {
            char hex[16];
            std::snprintf(hex, sizeof hex, "%04X", status);
            return std::string(hex);
        }() + ")");
}

VertexArray VertexArray::create() {
    GLuint id = 0;
    glCreateVertexArrays(1, &id);
    return VertexArray(id);
}

Query Query::create(GLenum target) {
    GLuint id = 0;
    glCreateQueries(target, 1, &id);
    return Query(id);
}

Shader Shader::compile(GLenum stage, std::string_view source, std::string_view name) {
    Shader shader(glCreateShader(stage));
    const GLchar* text = source.data();
    const auto length = GLint(source.size());
    glShaderSource(shader.id(), 1, &text, &length);
    glCompileShader(shader.id());
    GLint ok = GL_FALSE;
    glGetShaderiv(shader.id(), GL_COMPILE_STATUS, &ok);
    if (ok != GL_TRUE)
        throw Error(std::string(name), std::nullopt,
                    "shader compilation failed:\n" + infoLog(shader.id(), glGetShaderiv, glGetShaderInfoLog));
    return shader;
}

Program Program::link(std::span<const Shader> shaders, std::string_view name) {
    Program program(glCreateProgram());
    for (const Shader& shader : shaders) glAttachShader(program.id(), shader.id());
    glLinkProgram(program.id());
    for (const Shader& shader : shaders) glDetachShader(program.id(), shader.id());
    GLint ok = GL_FALSE;
    glGetProgramiv(program.id(), GL_LINK_STATUS, &ok);
    if (ok != GL_TRUE)
        throw Error(std::string(name), std::nullopt,
                    "program link failed:\n" + infoLog(program.id(), glGetProgramiv, glGetProgramInfoLog));
    return program;
}

} // namespace lightskin::gl
