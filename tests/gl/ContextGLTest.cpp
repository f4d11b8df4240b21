#include "GlTestEnvironment.h"

#include <lightskin/core/Error.h>
#include <lightskin/gl/DebugOutput.h>
#include <lightskin/gl/GpuTimer.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/gl/SelfTest.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <chrono>
#include <cmath>
#include <numeric>
#include <random>

namespace lightskin::test {
namespace {

using ContextGLTest = GlTest;

TEST_F(ContextGLTest, GivesOpenGl45CoreAndNamesTheRenderer) {
    GLint major = 0, minor = 0, profile = 0;
    glGetIntegerv(GL_MAJOR_VERSION, &major);
    glGetIntegerv(GL_MINOR_VERSION, &minor);
    glGetIntegerv(GL_CONTEXT_PROFILE_MASK, &profile);
    EXPECT_GE(major * 10 + minor, 45);
    EXPECT_TRUE(profile & GL_CONTEXT_CORE_PROFILE_BIT);
    EXPECT_FALSE(GlTestEnvironment::context().renderer().empty());
    EXPECT_NE(GlTestEnvironment::context().describe().find(GlTestEnvironment::context().platformName()),
              std::string::npos);
}

// Edge function of the directed edge a->b at p (positive on the left).
double edge(cv::Point2d a, cv::Point2d b, cv::Point2d p) {
    return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
}

TEST_F(ContextGLTest, RasterisesTheTriangleExactlyWherePixelCentresAreInside) {
    constexpr int size = 64;
    const cv::Mat image = gl::renderSelfTestTriangle(size, size);
    ASSERT_EQ(image.type(), CV_8UC4);
    // NDC vertices mapped to window coordinates (GL: y up), then to image rows (y down).
    const auto toImage = [](double x, double y) { return cv::Point2d((x + 1) / 2 * size, size - (y + 1) / 2 * size); };
    const cv::Point2d a = toImage(-0.5, -0.5), b = toImage(0.5, -0.5), c = toImage(0.0, 0.5);
    int inside = 0, mismatches = 0;
    for (int row = 0; row < size; ++row)
        for (int col = 0; col < size; ++col) {
            const cv::Point2d centre(col + 0.5, row + 0.5);
            const double e0 = edge(a, b, centre), e1 = edge(b, c, centre), e2 = edge(c, a, centre);
            const bool onEdge = std::abs(e0) < 1e-9 || std::abs(e1) < 1e-9 || std::abs(e2) < 1e-9;
            // Image rows flip orientation, so inside means all edge functions negative.
            const bool expectedInside = e0 < 0 && e1 < 0 && e2 < 0;
            const cv::Vec4b pixel = image.at<cv::Vec4b>(row, col);
            if (onEdge) continue; // the top-left fill rule decides these; either answer is correct
            inside += expectedInside;
            if ((pixel[0] == 255) != expectedInside || pixel[1] != 0 || pixel[2] != 0 || pixel[3] != 255) ++mismatches;
        }
    EXPECT_GT(inside, 400); // area is 32 * 32 / 2 = 512 px
    EXPECT_EQ(mismatches, 0);
}

TEST_F(ContextGLTest, ShaderDefinesReachTheShader) {
    const cv::Mat image = gl::renderSelfTestTriangle(32, 32, 0.5f);
    // 0.5 * 255 = 127.5: unorm conversion rounds to nearest, either neighbour is allowed.
    const int red = image.at<cv::Vec4b>(18, 16)[0];
    EXPECT_TRUE(red == 127 || red == 128) << red;
}

TEST_F(ContextGLTest, ComputeShaderSumsABuffer) {
    std::mt19937 random(42);
    std::vector<std::uint32_t> values(100003); // not a multiple of the work-group size
    for (auto& v : values) v = std::uint32_t(random() % 1000);
    const std::uint32_t expected = std::accumulate(values.begin(), values.end(), 0u);
    EXPECT_EQ(gl::sumOnGpu(values), expected);
    EXPECT_EQ(gl::sumOnGpu({}), 0u);
}

TEST_F(ContextGLTest, DebugCallbackCatchesADeliberateGlError) {
    ASSERT_EQ(gl::DebugOutput::errorCount(), 0u);
    glEnable(GLenum(0x1234)); // not a capability: GL_INVALID_ENUM
    EXPECT_EQ(gl::DebugOutput::errorCount(), 1u);
    EXPECT_NE(gl::DebugOutput::lastError().find("GL:"), std::string::npos);
    EXPECT_THROW(gl::DebugOutput::throwIfErrors("deliberate"), Error);
    EXPECT_EQ(gl::DebugOutput::errorCount(), 0u); // throwIfErrors resets
}

TEST_F(ContextGLTest, ObjectsAreMoveOnlyOwnersThatDeleteTheirName) {
    gl::Buffer buffer = gl::Buffer::create(64);
    const GLuint id = buffer.id();
    ASSERT_NE(id, 0u);
    EXPECT_TRUE(glIsBuffer(id));
    gl::Buffer moved = std::move(buffer);
    EXPECT_EQ(buffer.id(), 0u); // NOLINT(bugprone-use-after-move): the empty state is the contract
    EXPECT_EQ(moved.id(), id);
    moved.reset();
    EXPECT_FALSE(glIsBuffer(id));

    gl::Texture texture = gl::Texture::create2D(GL_RGBA8, 4, 4);
    const GLuint released = texture.release();
    EXPECT_EQ(texture.id(), 0u);
    EXPECT_TRUE(glIsTexture(released));
    gl::Texture adopted = gl::Texture::wrap(released, 4, 4);
    EXPECT_EQ(adopted.id(), released);
}

TEST_F(ContextGLTest, IncompleteFramebufferIsReportedByName) {
    gl::Framebuffer framebuffer = gl::Framebuffer::create();
    try {
        framebuffer.checkComplete("empty test framebuffer");
        FAIL() << "an FBO without attachments is incomplete";
    } catch (const Error& error) {
        EXPECT_EQ(error.source(), "empty test framebuffer");
    }
}

TEST_F(ContextGLTest, GpuTimerReportsStagesInOrder) {
    gl::GpuStageTimer timer = gl::GpuStageTimer::create(4);
    std::vector<gl::StageTime> times;
    for (int frame = 0; frame < 2; ++frame) { // the second frame reuses the queries
        // No wall-clock threshold (it would flake on a loaded machine). Instead: the stages lie
        // inside the frame, so each one, and their sum, is at most the wall time from before
        // beginFrame() to after collect() (which waits for the results). Load stretches both
        // sides alike. Slack 0.01 ms: timestamp granularity (llvmpipe reads the same monotonic
        // nanosecond clock; GPUs tick at >= 12.5 MHz, 80 ns).
        const auto wallStart = std::chrono::steady_clock::now();
        timer.beginFrame();
        timer.begin("triangle");
        (void)gl::renderSelfTestTriangle(128, 128);
        timer.end();
        timer.begin("sum");
        std::vector<std::uint32_t> values(4096, 1);
        EXPECT_EQ(gl::sumOnGpu(values), 4096u);
        timer.end();
        timer.collect(times);
        const double wallMs =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wallStart).count();
        ASSERT_EQ(times.size(), 2u);
        EXPECT_EQ(times[0].name, "triangle");
        EXPECT_EQ(times[1].name, "sum");
        double sumMs = 0.0;
        for (const auto& stage : times) {
            EXPECT_TRUE(std::isfinite(stage.milliseconds)) << stage.name;
            EXPECT_GE(stage.milliseconds, 0.0) << stage.name;
            sumMs += stage.milliseconds;
        }
        EXPECT_LE(sumMs, wallMs + 0.01) << "the stages cannot take longer than the frame around them";
    }
}

} // namespace
} // namespace lightskin::test
