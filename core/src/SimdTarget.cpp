#include <lightskin/core/SimdTarget.h>

#include <lightskin/core/Error.h>

#include <hwy/highway.h>
#include <hwy/targets.h>

#include <cstdint>
#include <cstdlib>
#include <mutex>

namespace lightskin::core {
namespace {

// Highway's target bits: a lower bit is a better instruction set. HWY_TARGETS here equals the kernels'
// set: they are compiled with the same flags (the x86-64 baseline, no -m options).
std::int64_t lowestBit(std::int64_t bits) { return bits & -bits; }

std::int64_t generatedTargetNamed(std::string_view name) {
    for (std::int64_t bits = HWY_TARGETS; bits != 0; bits &= bits - 1)
        if (name == hwy::TargetName(lowestBit(bits))) return lowestBit(bits);
    return 0;
}

std::string generatedTargetNames() {
    std::string names;
    for (std::int64_t bits = HWY_TARGETS; bits != 0; bits &= bits - 1)
        names += std::string(names.empty() ? "" : ", ") + hwy::TargetName(lowestBit(bits));
    return names;
}

/// What dispatch may choose from, fixed once per process: the supported targets, no better than the cap.
std::int64_t gAvailableTargets = 0;
/// Highway's mask when nothing is restricted: 0 (its own choice of every supported target) or the cap.
std::int64_t gDefaultMask = 0;

} // namespace

void applySimdTargetCap() {
    static std::once_flag once;
    std::call_once(once, [] {
        hwy::SetSupportedTargetsForTest(0);
        gAvailableTargets = hwy::SupportedTargets() & HWY_TARGETS;
        const char* value = std::getenv(kSimdTargetVariable);
        if (value == nullptr || *value == '\0') return;
        const std::int64_t capBit = generatedTargetNamed(value);
        if (capBit == 0)
            throw Error(kSimdTargetVariable, std::nullopt,
                        "'" + std::string(value) + "' is not an instruction set of this build (" +
                            generatedTargetNames() + ")");
        // Every bit at or above the cap's is an instruction set no better than it.
        gAvailableTargets &= ~(capBit - 1);
        gDefaultMask = gAvailableTargets;
        hwy::SetSupportedTargetsForTest(gDefaultMask);
    });
}

std::vector<std::string> simdTargets() {
    applySimdTargetCap();
    std::vector<std::string> names;
    for (std::int64_t bits = gAvailableTargets; bits != 0; bits &= bits - 1) names.emplace_back(hwy::TargetName(lowestBit(bits)));
    return names;
}

std::string activeSimdTarget() {
    applySimdTargetCap();
    return hwy::TargetName(lowestBit(hwy::SupportedTargets() & HWY_TARGETS));
}

void restrictSimdTarget(std::string_view name) {
    applySimdTargetCap();
    if (name.empty()) {
        hwy::SetSupportedTargetsForTest(gDefaultMask);
        return;
    }
    const std::int64_t target = generatedTargetNamed(name);
    if ((target & gAvailableTargets) != 0) {
        hwy::SetSupportedTargetsForTest(target);
        return;
    }
    std::string available;
    for (const std::string& supported : simdTargets()) available += (available.empty() ? "" : ", ") + supported;
    throw Error("SIMD target", std::nullopt,
                "'" + std::string(name) + "' is not one this build and CPU support (" + available + ")");
}

} // namespace lightskin::core
