#include <lightskin/core/Error.h>
#include <lightskin/core/JsonError.h>

#include <cstdio>
#include <cstdlib>

namespace lightskin {

namespace {
std::string formatError(const std::string& source, std::optional<std::int64_t> frame, const std::string& cause) {
    std::string text;
    if (!source.empty()) text += source + ": ";
    if (frame) text += "frame " + std::to_string(*frame) + ": ";
    return text + cause;
}
} // namespace

Error::Error(std::string source, std::optional<std::int64_t> frame, std::string cause)
    : std::runtime_error(formatError(source, frame, cause)), source_(std::move(source)), frame_(frame),
      cause_(std::move(cause)) {}

Error::Error(std::string cause) : Error({}, std::nullopt, std::move(cause)) {}

std::string jsonErrorCause(const char* what) {
    std::string text(what);
    if (text.starts_with("[json.exception"))
        if (const std::size_t end = text.find("] "); end != std::string::npos) text.erase(0, end + 2);
    if (const std::size_t echo = text.find("; last read: "); echo != std::string::npos) text.erase(echo);
    for (char& c : text)
        if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) c = '?';
    return text;
}

void assertionFailed(const char* expression, const char* function, const char* message) {
    std::fprintf(stderr, "lightskin: assertion failed in %s: %s (%s)\n", function, message, expression);
    std::abort();
}

} // namespace lightskin
