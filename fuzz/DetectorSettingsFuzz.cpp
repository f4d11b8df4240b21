// Fuzz target: AprilTag detector settings JSON through tracking::detectorSettingsFromJson (in
// memory), then TagDetector::create, which checks the ranges.
#include <lightskin/core/Error.h>
#include <lightskin/tracking/TagDetector.h>

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        const auto settings = lightskin::tracking::detectorSettingsFromJson(
            std::string(reinterpret_cast<const char*>(data), size), "fuzz-detector.json");
        (void)lightskin::tracking::TagDetector::create(settings);
    } catch (const lightskin::Error&) {
    }
    return 0;
}
