#include "GlTestEnvironment.h"

#include <lightskin/gl/DebugOutput.h>

#include <epoxy/gl.h>

#include <memory>

namespace lightskin::test {

namespace {
std::unique_ptr<gl::Context>& sharedContext() {
    static std::unique_ptr<gl::Context> context;
    return context;
}
} // namespace

void GlTestEnvironment::SetUp() { sharedContext() = gl::createHeadlessContext(); }
void GlTestEnvironment::TearDown() { sharedContext().reset(); }
gl::Context& GlTestEnvironment::context() { return *sharedContext(); }

void GlTest::SetUp() {
    ASSERT_TRUE(sharedContext()) << "GL tests need GlTestMain (lightskin_add_test(... GL))";
    sharedContext()->makeCurrent();
    gl::DebugOutput::resetErrors();
}

void GlTest::TearDown() {
    glFinish();
    EXPECT_EQ(gl::DebugOutput::errorCount(), 0u) << "GL error(s) reported, last: " << gl::DebugOutput::lastError();
}

} // namespace lightskin::test
