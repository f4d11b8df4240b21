#pragma once
// Move-only RAII owners of OpenGL objects (GL 4.5 direct state access).
//
// Every object has an explicit empty state (id() == 0), is created by a static create() that needs
// a current context, is deleted in the destructor on the thread whose context is current, and
// can adopt or give up a foreign handle with wrap()/release() (for engines that own the context).
// Destroying an object after its context is gone is a programmer error the caller must avoid:
// destroy GL objects before the Context that made them.

#include <epoxy/gl.h>

#include <span>
#include <string_view>
#include <utility>

namespace lightskin::gl {

namespace detail {
template <void (*Delete)(GLuint)>
class Handle {
public:
    Handle() noexcept = default;
    ~Handle() { reset(); }
    Handle(Handle&& other) noexcept : id_(std::exchange(other.id_, 0)) {}
    Handle& operator=(Handle&& other) noexcept {
        if (this != &other) {
            reset();
            id_ = std::exchange(other.id_, 0);
        }
        return *this;
    }
    Handle(const Handle&) = delete;
    Handle& operator=(const Handle&) = delete;

    GLuint id() const noexcept { return id_; }
    explicit operator bool() const noexcept { return id_ != 0; }
    /// Gives up ownership; the caller deletes the object.
    GLuint release() noexcept { return std::exchange(id_, 0); }
    void reset() noexcept {
        if (id_ != 0) Delete(id_);
        id_ = 0;
    }

protected:
    explicit Handle(GLuint id) noexcept : id_(id) {}

private:
    GLuint id_ = 0;
};

void deleteBuffer(GLuint id);
void deleteTexture(GLuint id);
void deleteFramebuffer(GLuint id);
void deleteRenderbuffer(GLuint id);
void deleteVertexArray(GLuint id);
void deleteQuery(GLuint id);
void deleteShader(GLuint id);
void deleteProgram(GLuint id);
} // namespace detail

class Buffer : public detail::Handle<detail::deleteBuffer> {
public:
    Buffer() noexcept = default;
    /// Immutable storage of `sizeBytes` (glNamedBufferStorage); `data` may be null.
    static Buffer create(GLsizeiptr sizeBytes, const void* data = nullptr, GLbitfield flags = GL_DYNAMIC_STORAGE_BIT);
    /// Takes ownership of an existing buffer name.
    static Buffer wrap(GLuint id) noexcept { return Buffer(id); }
    GLsizeiptr size() const noexcept { return size_; }
    void upload(GLintptr offsetBytes, GLsizeiptr sizeBytes, const void* data);

private:
    explicit Buffer(GLuint id) noexcept : Handle(id) {}
    GLsizeiptr size_ = 0;
};

class Texture : public detail::Handle<detail::deleteTexture> {
public:
    Texture() noexcept = default;
    /// 2D texture with immutable storage, one mip level, nearest filtering, clamp to edge.
    static Texture create2D(GLenum internalFormat, GLsizei width, GLsizei height, GLsizei levels = 1);
    static Texture wrap(GLuint id, GLsizei width, GLsizei height) noexcept { return Texture(id, width, height); }
    GLsizei width() const noexcept { return width_; }
    GLsizei height() const noexcept { return height_; }

private:
    Texture(GLuint id, GLsizei width, GLsizei height) noexcept : Handle(id), width_(width), height_(height) {}
    GLsizei width_ = 0, height_ = 0;
};

class Renderbuffer : public detail::Handle<detail::deleteRenderbuffer> {
public:
    Renderbuffer() noexcept = default;
    static Renderbuffer create(GLenum internalFormat, GLsizei width, GLsizei height);

private:
    explicit Renderbuffer(GLuint id) noexcept : Handle(id) {}
};

class Framebuffer : public detail::Handle<detail::deleteFramebuffer> {
public:
    Framebuffer() noexcept = default;
    static Framebuffer create();
    static Framebuffer wrap(GLuint id) noexcept { return Framebuffer(id); }
    void attach(GLenum attachment, const Texture& texture, GLint level = 0);
    void attach(GLenum attachment, const Renderbuffer& renderbuffer);
    /// Throws lightskin::Error naming `what` if the framebuffer is incomplete.
    void checkComplete(std::string_view what) const;

private:
    explicit Framebuffer(GLuint id) noexcept : Handle(id) {}
};

class VertexArray : public detail::Handle<detail::deleteVertexArray> {
public:
    VertexArray() noexcept = default;
    static VertexArray create();

private:
    explicit VertexArray(GLuint id) noexcept : Handle(id) {}
};

class Query : public detail::Handle<detail::deleteQuery> {
public:
    Query() noexcept = default;
    static Query create(GLenum target);

private:
    explicit Query(GLuint id) noexcept : Handle(id) {}
};

class Shader : public detail::Handle<detail::deleteShader> {
public:
    Shader() noexcept = default;
    /// Compiles `source`; throws lightskin::Error naming `name` with the driver's log on failure.
    static Shader compile(GLenum stage, std::string_view source, std::string_view name);

private:
    explicit Shader(GLuint id) noexcept : Handle(id) {}
};

class Program : public detail::Handle<detail::deleteProgram> {
public:
    Program() noexcept = default;
    /// Links the given shaders; throws lightskin::Error naming `name` with the driver's log on failure.
    static Program link(std::span<const Shader> shaders, std::string_view name);
    static Program wrap(GLuint id) noexcept { return Program(id); }
    void use() const { glUseProgram(id()); }
    /// -1 when the uniform does not exist (or was optimised away).
    GLint uniformLocation(const char* uniformName) const { return glGetUniformLocation(id(), uniformName); }

private:
    explicit Program(GLuint id) noexcept : Handle(id) {}
};

} // namespace lightskin::gl
