#pragma once
// KHR_debug output (core in GL 4.3). Driver messages are logged; messages of type
// GL_DEBUG_TYPE_ERROR are also counted, so tests fail on any GL error and applications can check
// after a stage. Synchronous output: the message arrives inside the offending call.

#include <cstdint>
#include <string>

namespace lightskin::gl {

class DebugOutput {
public:
    /// Installs the callback on the current context. Called by the context factories when
    /// ContextOptions::debug is set; engines that own the context may call it themselves.
    static void install();
    /// Number of GL errors reported on this thread's contexts since the last reset.
    static std::uint64_t errorCount();
    /// The most recent error message (empty if none).
    static std::string lastError();
    static void resetErrors();
    /// Throws lightskin::Error naming `stage` if errors were reported since the last reset, then resets.
    static void throwIfErrors(const std::string& stage);
};

} // namespace lightskin::gl
