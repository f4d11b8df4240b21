#pragma once
// Logging facade over spdlog, so modules do not include spdlog in public headers.
// Messages go to stderr; the level is set once by the application (--verbose / --quiet).

#include <string_view>

namespace lightskin::log {

enum class Level { Debug, Info, Warning, Error, Off };

void setLevel(Level level);
void debug(std::string_view message);
void info(std::string_view message);
void warning(std::string_view message);
void error(std::string_view message);

} // namespace lightskin::log
