#pragma once
// One headless GL 4.5 context per GL test binary (creating one per test costs ~50 ms on
// llvmpipe); GlTest checks after every test that the KHR_debug callback saw no GL error.
#include <lightskin/gl/Context.h>

#include <gtest/gtest.h>

namespace lightskin::test {

class GlTestEnvironment : public ::testing::Environment {
public:
    void SetUp() override;
    void TearDown() override;
    static gl::Context& context();
};

/// Base fixture of GL tests: fails the test if the debug callback reported a GL error during it.
/// Tests that provoke an error on purpose call gl::DebugOutput::resetErrors() after checking it.
class GlTest : public ::testing::Test {
protected:
    void SetUp() override;
    void TearDown() override;
};

} // namespace lightskin::test
