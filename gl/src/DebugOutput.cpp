#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/gl/DebugOutput.h>

#include <epoxy/gl.h>

#include <cstring>

namespace lightskin::gl {

namespace {
// Per thread, like GL contexts themselves.
thread_local std::uint64_t errorCounter = 0;
thread_local std::string lastErrorMessage;

void GLAPIENTRY onDebugMessage(GLenum source, GLenum type, GLuint id, GLenum severity, GLsizei length, const GLchar* message,
                               const void*) {
    const std::string text = "GL: " + std::string(message, length > 0 ? std::size_t(length) : std::strlen(message)) +
                             " (id " + std::to_string(id) + ")";
    if (source == GL_DEBUG_SOURCE_SHADER_COMPILER) {
        // Compile and link failures are thrown with the full log by Shader/Program; Mesa also
        // reports them here as errors, which would count them twice.
        log::debug(text);
    } else if (type == GL_DEBUG_TYPE_ERROR) {
        ++errorCounter;
        lastErrorMessage = text;
        log::error(text);
    } else if (severity == GL_DEBUG_SEVERITY_HIGH || severity == GL_DEBUG_SEVERITY_MEDIUM) {
        log::warning(text);
    } else if (severity != GL_DEBUG_SEVERITY_NOTIFICATION) {
        log::debug(text);
    }
}
} // namespace

void DebugOutput::install() {
    glEnable(GL_DEBUG_OUTPUT);
    glEnable(GL_DEBUG_OUTPUT_SYNCHRONOUS);
    glDebugMessageCallback(onDebugMessage, nullptr);
    glDebugMessageControl(GL_DONT_CARE, GL_DONT_CARE, GL_DONT_CARE, 0, nullptr, GL_TRUE);
}

std::uint64_t DebugOutput::errorCount() { return errorCounter; }
std::string DebugOutput::lastError() { return lastErrorMessage; }
void DebugOutput::resetErrors() {
    errorCounter = 0;
    lastErrorMessage.clear();
}

void DebugOutput::throwIfErrors(const std::string& stage) {
    if (errorCounter == 0) return;
    const std::string message = std::to_string(errorCounter) + " GL error(s), last: " + lastErrorMessage;
    resetErrors();
    throw Error(stage, std::nullopt, message);
}

} // namespace lightskin::gl
