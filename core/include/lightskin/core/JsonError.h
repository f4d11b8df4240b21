#pragma once
// nlohmann-json's exception texts turned into the cause of a lightskin::Error (core/Error.h).

#include <string>

namespace lightskin {

/// The cause in nlohmann-json's exception text `what`: without the library's
/// "[json.exception.parse_error.101] " prefix and without its "; last read: '...'" echo of the input
/// (raw bytes of a garbage file); any other control or non-ASCII byte is shown as '?'.
std::string jsonErrorCause(const char* what);

} // namespace lightskin
