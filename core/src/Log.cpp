#include <lightskin/core/Log.h>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

namespace lightskin::log {

namespace {
spdlog::logger& logger() {
    // stderr, so that stdout stays clean for machine-readable output (info --json, CSV).
    // Not registered in spdlog's global registry: an embedding host may use spdlog itself (or load
    // liblightskin.so beside another copy of lightskin), and a second "lightskin" would throw there.
    static const std::shared_ptr<spdlog::logger> instance = [] {
        auto created =
            std::make_shared<spdlog::logger>("lightskin", std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
        created->set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
        return created;
    }();
    return *instance;
}
} // namespace

void setLevel(Level level) {
    switch (level) {
    case Level::Debug: logger().set_level(spdlog::level::debug); break;
    case Level::Info: logger().set_level(spdlog::level::info); break;
    case Level::Warning: logger().set_level(spdlog::level::warn); break;
    case Level::Error: logger().set_level(spdlog::level::err); break;
    case Level::Off: logger().set_level(spdlog::level::off); break;
    }
}

void debug(std::string_view message) { logger().debug(message); }
void info(std::string_view message) { logger().info(message); }
void warning(std::string_view message) { logger().warn(message); }
void error(std::string_view message) { logger().error(message); }

} // namespace lightskin::log
