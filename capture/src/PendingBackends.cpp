// Temporary: the live and TUM backends land in the next commits.
#include "Sources.h"

#include <lightskin/core/Error.h>

namespace lightskin::capture::detail {
std::unique_ptr<FrameSource> openFreenectSource(int, const FrameSourceOptions&) {
    throw Error("freenect", std::nullopt, "libfreenect is not supported yet");
}
} // namespace lightskin::capture::detail
