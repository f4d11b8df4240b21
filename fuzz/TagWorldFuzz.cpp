// Fuzz target: tag-world JSON through tracking::TagWorld::fromJson (in memory).
#include <lightskin/core/Error.h>
#include <lightskin/tracking/TagWorld.h>

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        (void)lightskin::tracking::TagWorld::fromJson(std::string(reinterpret_cast<const char*>(data), size),
                                                      "fuzz-tags.json");
    } catch (const lightskin::Error&) {
    }
    return 0;
}
