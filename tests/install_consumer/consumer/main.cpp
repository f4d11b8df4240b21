#include <lightskin/core/Pose.h>
#include <lightskin/gl/Context.h>
#include <lightskin/gl/SelfTest.h>

#include <cstdio>
#include <numeric>
#include <vector>

int main() {
    auto context = lightskin::gl::createHeadlessContext();
    std::vector<std::uint32_t> values(1000);
    std::iota(values.begin(), values.end(), 0u);
    const bool ok = lightskin::gl::sumOnGpu(values) == 499500u &&
                    lightskin::Pose().inverse().translation().x == 0.0;
    std::printf(ok ? "consumer ok\n" : "consumer FAILED\n");
    return ok ? 0 : 1;
}
