// The run-time choice of the SIMD instruction set (core/SimdTarget.h): every target this CPU supports can be
// selected and is the one the kernels report, the scalar fallback is always there, and LIGHTSKIN_SIMD_TARGET
// caps the choice. The order of the targets is checked against Highway's own target bits, not against the
// list the code under test builds.
#include <lightskin/core/Error.h>
#include <lightskin/core/SimdTarget.h>

#include <gtest/gtest.h>
#include <hwy/highway.h>
#include <hwy/targets.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace lightskin::test {
namespace {

/// Highway's bit for a target name (a lower bit is a better instruction set), 0 if not generated.
std::int64_t bitOf(const std::string& name) {
    for (std::int64_t bits = HWY_TARGETS; bits != 0; bits &= bits - 1)
        if (name == hwy::TargetName(bits & -bits)) return bits & -bits;
    return 0;
}

TEST(SimdTargetTest, ListsSupportedTargetsBestFirstEndingWithTheFallback) {
    const std::vector<std::string> targets = core::simdTargets();
    ASSERT_FALSE(targets.empty());
    const std::string fallback = targets.back();
    EXPECT_TRUE(fallback == "SCALAR" || fallback == "EMU128") << fallback;
    for (std::size_t i = 0; i < targets.size(); ++i) {
        const std::int64_t bit = bitOf(targets[i]);
        ASSERT_NE(bit, 0) << targets[i] << " is not a target of this build";
        EXPECT_NE(hwy::SupportedTargets() & bit, 0) << targets[i] << " is not supported by this CPU";
        if (i > 0) {
            EXPECT_GT(bit, bitOf(targets[i - 1])) << targets[i] << " listed after a worse target";
        }
    }
    EXPECT_EQ(core::activeSimdTarget(), targets.front());
}

TEST(SimdTargetTest, EachTargetCanBeSelectedForAScopeAndTheDefaultReturns) {
    const std::vector<std::string> targets = core::simdTargets();
    for (const std::string& target : targets) {
        const core::SimdTargetScope scope(target);
        EXPECT_EQ(core::activeSimdTarget(), target);
        EXPECT_EQ(core::simdTargets(), targets) << "selecting a target must not shrink the list";
    }
    EXPECT_EQ(core::activeSimdTarget(), targets.front());
}

TEST(SimdTargetTest, AnUnknownTargetIsAnErrorNamingIt) {
    try {
        core::restrictSimdTarget("NO_SUCH_TARGET");
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("NO_SUCH_TARGET"), std::string::npos) << e.what();
    }
    EXPECT_EQ(core::activeSimdTarget(), core::simdTargets().front());
}

// The cap is read once per process, so each case runs in a fresh process (a threadsafe death test
// re-executes this binary), with the variable set there.
int runWithCap(const char* cap) {
    if (setenv(core::kSimdTargetVariable, cap, 1) != 0) return 10;
    try {
        const std::vector<std::string> targets = core::simdTargets();
        const std::int64_t capBit = bitOf(cap);
        for (const std::string& target : targets)
            if (bitOf(target) < capBit) return 11; // a better target than the cap is available
        // the cap binds when the CPU has it; if not, the CPU's best (which is worse) runs
        const bool supported = (hwy::SupportedTargets() & capBit) != 0;
        if (supported && core::activeSimdTarget() != cap) return 12;
        if (core::activeSimdTarget() != targets.front()) return 13;
        if (targets.back() != "SCALAR" && targets.back() != "EMU128") return 14;
        return 0;
    } catch (const Error& e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 20;
    }
}

TEST(SimdTargetDeathTest, TheEnvironmentCapsTheChoice) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    for (const char* cap : {"AVX3", "AVX2", "SSE4", "SCALAR"}) {
        if (bitOf(cap) == 0) continue; // not generated on this architecture
        SCOPED_TRACE(cap);
        EXPECT_EXIT(std::exit(runWithCap(cap)), ::testing::ExitedWithCode(0), "");
    }
}

TEST(SimdTargetDeathTest, ABadCapIsAnErrorNamingTheVariableAndTheValue) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    EXPECT_EXIT(std::exit(runWithCap("AVX9000")), ::testing::ExitedWithCode(20),
                "LIGHTSKIN_SIMD_TARGET.*AVX9000.*not an instruction set of this build");
}

} // namespace
} // namespace lightskin::test
