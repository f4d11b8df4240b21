#include "GlTestEnvironment.h"

#include <lightskin/core/Error.h>
#include <lightskin/gl/ShaderLibrary.h>

#include <gtest/gtest.h>

#include <array>

namespace lightskin::test {
namespace {

using ShaderLibraryGLTest = GlTest;

constexpr std::array<gl::EmbeddedFile, 1> brokenShaders{{
    {"broken.comp", "#version 450 core\nlayout(local_size_x = 1) in;\nvoid main() { undefined_function(); }\n"},
}};

TEST_F(ShaderLibraryGLTest, CompileErrorNamesTheFileAndVariant) {
    const gl::ShaderLibrary library{brokenShaders};
    const std::string defines[] = {"VARIANT_X 1"};
    try {
        (void)library.buildProgram({{GL_COMPUTE_SHADER, "broken.comp"}}, defines);
        FAIL() << "compiling a broken shader must throw";
    } catch (const Error& error) {
        EXPECT_NE(error.source().find("broken.comp"), std::string::npos) << error.what();
        EXPECT_NE(error.source().find("VARIANT_X 1"), std::string::npos) << error.what();
        EXPECT_NE(error.cause().find("compilation failed"), std::string::npos);
    }
}

TEST_F(ShaderLibraryGLTest, BuildsTheEmbeddedSelfTestPrograms) {
    const gl::ShaderLibrary library{};
    EXPECT_NO_THROW((void)library.buildProgram({{GL_COMPUTE_SHADER, "selftest_sum.comp"}}));
}

} // namespace
} // namespace lightskin::test
