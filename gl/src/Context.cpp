#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/gl/Context.h>
#include <lightskin/gl/DebugOutput.h>

#include <epoxy/gl.h>

namespace lightskin::gl {

namespace {
std::string glString(GLenum name) {
    const auto* text = reinterpret_cast<const char*>(glGetString(name));
    return text ? std::string(text) : std::string("(unknown)");
}
} // namespace

std::string Context::renderer() const { return glString(GL_RENDERER); }
std::string Context::vendor() const { return glString(GL_VENDOR); }
std::string Context::version() const { return glString(GL_VERSION); }
std::string Context::describe() const { return renderer() + " | " + version() + " | " + platformName(); }

void Context::finishInitialisation(const ContextOptions& options) {
    GLint major = 0, minor = 0;
    glGetIntegerv(GL_MAJOR_VERSION, &major);
    glGetIntegerv(GL_MINOR_VERSION, &minor);
    if (major * 10 + minor < options.versionMajor * 10 + options.versionMinor)
        throw Error(platformName(), std::nullopt,
                    "OpenGL " + std::to_string(major) + "." + std::to_string(minor) + " context, need " +
                        std::to_string(options.versionMajor) + "." + std::to_string(options.versionMinor) +
                        " core (renderer: " + renderer() + ")");
    if (options.debug) DebugOutput::install();
    log::info("OpenGL context: " + describe());
}

} // namespace lightskin::gl
