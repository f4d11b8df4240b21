#pragma once
// Errors that carry where they happened: the file (or device/URI), the frame, and the cause.
// Anything that can fail at run time because of its input (a file, a device, a shader, a config)
// throws lightskin::Error; programmer errors are assertions (LIGHTSKIN_ASSERT).

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

namespace lightskin {

class Error : public std::runtime_error {
public:
    /// `source`: file path, device URI or config key the error is about (may be empty).
    /// `frame`: frame index in that source, when the error is about one frame.
    /// `cause`: what went wrong, in words a user can act on.
    Error(std::string source, std::optional<std::int64_t> frame, std::string cause);
    explicit Error(std::string cause);

    const std::string& source() const noexcept { return source_; }
    std::optional<std::int64_t> frame() const noexcept { return frame_; }
    const std::string& cause() const noexcept { return cause_; }

private:
    std::string source_;
    std::optional<std::int64_t> frame_;
    std::string cause_;
};

[[noreturn]] void assertionFailed(const char* expression, const char* function, const char* message);

} // namespace lightskin

/// Programmer-error check, kept in release builds. The message names the function.
#define LIGHTSKIN_ASSERT(condition, message)                                                           \
    do {                                                                                               \
        if (!(condition)) ::lightskin::assertionFailed(#condition, __PRETTY_FUNCTION__, message);      \
    } while (false)
