#include <lightskin/core/Error.h>
#include <lightskin/gl/ShaderLibrary.h>

#include <gtest/gtest.h>

#include <array>

namespace lightskin::test {
namespace {

constexpr std::array<gl::EmbeddedFile, 5> files{{
    {"main.frag", "#version 450 core\n#include \"common.glsl\"\n#include \"common.glsl\"\nvoid main() {}\n"},
    {"common.glsl", "float helper() { return 1.0; }\n"},
    {"cycle_a.glsl", "#version 450 core\n#include \"cycle_b.glsl\"\n"},
    {"cycle_b.glsl", "#include \"cycle_a.glsl\"\n"},
    {"bad_include.frag", "#version 450 core\n#include common.glsl\n"},
}};

TEST(ShaderLibraryTest, ResolvesIncludesOnceAndInsertsDefinesAfterVersion) {
    const gl::ShaderLibrary library{files};
    const std::string defines[] = {"GLOSSY 1", "K_CACHE 128"};
    const std::string text = library.preprocess("main.frag", defines);
    EXPECT_TRUE(text.starts_with("#version 450 core\n#define GLOSSY 1\n#define K_CACHE 128\n")) << text;
    const std::size_t first = text.find("float helper()");
    ASSERT_NE(first, std::string::npos);
    EXPECT_EQ(text.find("float helper()", first + 1), std::string::npos) << "included twice:\n" << text;
    EXPECT_EQ(text.find("#include"), std::string::npos);
}

TEST(ShaderLibraryTest, MissingFileNamesTheFile) {
    const gl::ShaderLibrary library{files};
    try {
        (void)library.raw("nope.frag");
        FAIL();
    } catch (const Error& error) {
        EXPECT_EQ(error.source(), "nope.frag");
    }
}

TEST(ShaderLibraryTest, IncludeCyclesTerminateAndMalformedIncludesAreErrors) {
    const gl::ShaderLibrary library{files};
    EXPECT_NO_THROW((void)library.preprocess("cycle_a.glsl")); // each file at most once breaks the cycle
    EXPECT_THROW((void)library.preprocess("bad_include.frag"), Error);
}

TEST(ShaderLibraryTest, GlModuleShadersAreEmbedded) {
    const gl::ShaderLibrary library{};
    EXPECT_TRUE(library.raw("fullscreen.vert").starts_with("#version 450 core"));
}

} // namespace
} // namespace lightskin::test
