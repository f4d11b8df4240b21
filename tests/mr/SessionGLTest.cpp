// mr::Session on the bundled synthetic recording (320x240, ground-truth poses): the host's GL
// state survives a frame and a render; render() draws upright, exactly where the virtual content
// is, and its composite equals the CPU composite; host-submitted frames give the same image as the
// same frame read by a FrameSource; and the frame budget meets a budget on the steady recording.
#include "GlTestEnvironment.h"
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/mr/Session.h>

#include <epoxy/gl.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <map>
#include <string>
#include <vector>

using namespace lightskin;

namespace {

std::filesystem::path recording() { return test::sourceDir() / "recordings" / "synth-orbit"; }

/// The orbit scene (bunny + glossy cube) with fewer sparse points: the tests are about the session. On the GL
/// backend unless `backend` says otherwise (gi.backend; nullptr = the scene's default, auto), so the GL state and
/// image tests run the GL technique whatever renderer the machine has.
mr::SceneInput orbitScene(int sparsePoints = 256, const char* backend = "gl") {
    std::string text = test::readText(test::sourceDir() / "recordings" / "scenes" / "orbit.json");
    const std::string key = "\"sparsePoints\": 1024";
    const auto at = text.find(key);
    if (at != std::string::npos) text.replace(at, key.size(), "\"sparsePoints\": " + std::to_string(sparsePoints));
    if (backend != nullptr) {
        const std::string technique = "\"technique\": \"lightskin\",";
        const auto techniqueAt = text.find(technique);
        EXPECT_NE(techniqueAt, std::string::npos);
        text.insert(techniqueAt + technique.size(), std::string(" \"backend\": \"") + backend + "\",");
    }
    return mr::SceneInput::fromJson(text, test::sourceDir() / "recordings" / "scenes");
}

std::unique_ptr<mr::Session> sourceSession(const mr::SessionOptions& options = {},
                                           mr::SceneInput scene = orbitScene()) {
    return mr::Session::create(options, scene, capture::openFrameSource(recording(), {}));
}

// ---- The test's own record of GL state (independent of gl::StateGuard's list) ----

using StateRecord = std::map<std::string, std::vector<long long>>;

void getInts(StateRecord& r, const char* name, GLenum e, int count = 1) {
    GLint v[4] = {};
    glGetIntegerv(e, v);
    r[name] = std::vector<long long>(v, v + count);
}

StateRecord recordState() {
    StateRecord r;
    getInts(r, "draw framebuffer", GL_DRAW_FRAMEBUFFER_BINDING);
    getInts(r, "read framebuffer", GL_READ_FRAMEBUFFER_BINDING);
    getInts(r, "program", GL_CURRENT_PROGRAM);
    getInts(r, "vertex array", GL_VERTEX_ARRAY_BINDING);
    getInts(r, "array buffer", GL_ARRAY_BUFFER_BINDING);
    getInts(r, "element buffer", GL_ELEMENT_ARRAY_BUFFER_BINDING);
    getInts(r, "ssbo generic", GL_SHADER_STORAGE_BUFFER_BINDING);
    getInts(r, "ubo generic", GL_UNIFORM_BUFFER_BINDING);
    getInts(r, "pack buffer", GL_PIXEL_PACK_BUFFER_BINDING);
    getInts(r, "unpack buffer", GL_PIXEL_UNPACK_BUFFER_BINDING);
    getInts(r, "active texture", GL_ACTIVE_TEXTURE);
    getInts(r, "viewport", GL_VIEWPORT, 4);
    getInts(r, "scissor box", GL_SCISSOR_BOX, 4);
    getInts(r, "depth func", GL_DEPTH_FUNC);
    getInts(r, "blend src rgb", GL_BLEND_SRC_RGB);
    getInts(r, "blend dst rgb", GL_BLEND_DST_RGB);
    getInts(r, "blend equation", GL_BLEND_EQUATION_RGB);
    getInts(r, "cull face mode", GL_CULL_FACE_MODE);
    getInts(r, "front face", GL_FRONT_FACE);
    getInts(r, "pack alignment", GL_PACK_ALIGNMENT);
    getInts(r, "unpack alignment", GL_UNPACK_ALIGNMENT);
    getInts(r, "unpack row length", GL_UNPACK_ROW_LENGTH);
    GLboolean b[4] = {};
    glGetBooleanv(GL_DEPTH_WRITEMASK, b);
    r["depth mask"] = {b[0]};
    glGetBooleanv(GL_COLOR_WRITEMASK, b);
    r["colour mask"] = {b[0], b[1], b[2], b[3]};
    GLfloat f[4] = {};
    glGetFloatv(GL_COLOR_CLEAR_VALUE, f);
    r["clear colour x1000"] = {std::lround(f[0] * 1000), std::lround(f[1] * 1000), std::lround(f[2] * 1000),
                               std::lround(f[3] * 1000)};
    const std::pair<const char*, GLenum> enables[] = {{"blend", GL_BLEND},
                                                      {"depth test", GL_DEPTH_TEST},
                                                      {"cull face", GL_CULL_FACE},
                                                      {"scissor test", GL_SCISSOR_TEST},
                                                      {"stencil test", GL_STENCIL_TEST},
                                                      {"framebuffer srgb", GL_FRAMEBUFFER_SRGB}};
    for (const auto& [name, e] : enables) r[name] = {glIsEnabled(e)};
    for (GLuint i = 0; i < 8; ++i) {
        GLint name = 0;
        GLint64 start = 0, size = 0;
        glGetIntegeri_v(GL_SHADER_STORAGE_BUFFER_BINDING, i, &name);
        glGetInteger64i_v(GL_SHADER_STORAGE_BUFFER_START, i, &start);
        glGetInteger64i_v(GL_SHADER_STORAGE_BUFFER_SIZE, i, &size);
        r["ssbo " + std::to_string(i)] = {name, start, size};
        glGetIntegeri_v(GL_UNIFORM_BUFFER_BINDING, i, &name);
        r["ubo " + std::to_string(i)] = {name};
        glGetIntegeri_v(GL_IMAGE_BINDING_NAME, i, &name);
        r["image unit " + std::to_string(i)] = {name};
    }
    GLint active = 0;
    glGetIntegerv(GL_ACTIVE_TEXTURE, &active);
    for (GLuint u = 0; u < 12; ++u) {
        glActiveTexture(GL_TEXTURE0 + u);
        GLint t2d = 0, tCubeArray = 0, t2dArray = 0, sampler = 0;
        glGetIntegerv(GL_TEXTURE_BINDING_2D, &t2d);
        glGetIntegerv(GL_TEXTURE_BINDING_CUBE_MAP_ARRAY, &tCubeArray);
        glGetIntegerv(GL_TEXTURE_BINDING_2D_ARRAY, &t2dArray);
        glGetIntegerv(GL_SAMPLER_BINDING, &sampler);
        r["texture unit " + std::to_string(u)] = {t2d, tCubeArray, t2dArray, sampler};
    }
    glActiveTexture(GLenum(active));
    return r;
}

std::string differences(const StateRecord& before, const StateRecord& after) {
    std::string text;
    for (const auto& [name, values] : before) {
        if (after.at(name) == values) continue;
        text += name + ": {";
        for (long long v : values) text += std::to_string(v) + " ";
        text += "} -> {";
        for (long long v : after.at(name)) text += std::to_string(v) + " ";
        text += "}; ";
    }
    return text;
}

/// A host's objects and deliberately non-default state, as an engine mid-frame might have it.
struct HostGl {
    gl::Texture colour, other;
    gl::Renderbuffer depth;
    gl::Framebuffer framebuffer, readFramebuffer;
    gl::Buffer buffer;
    gl::VertexArray vertexArray;
    GLuint program = 0, sampler = 0;

    explicit HostGl(int w, int h) {
        colour = gl::Texture::create2D(GL_RGBA8, w, h);
        other = gl::Texture::create2D(GL_RGBA8, 16, 16);
        depth = gl::Renderbuffer::create(GL_DEPTH_COMPONENT32F, w, h);
        framebuffer = gl::Framebuffer::create();
        framebuffer.attach(GL_COLOR_ATTACHMENT0, colour);
        framebuffer.attach(GL_DEPTH_ATTACHMENT, depth);
        framebuffer.checkComplete("host framebuffer");
        readFramebuffer = gl::Framebuffer::create();
        readFramebuffer.attach(GL_COLOR_ATTACHMENT0, other);
        buffer = gl::Buffer::create(4096);
        vertexArray = gl::VertexArray::create();
        const char* vs = "#version 450 core\nvoid main() { gl_Position = vec4(0.0); }\n";
        const GLuint shader = glCreateShader(GL_VERTEX_SHADER);
        glShaderSource(shader, 1, &vs, nullptr);
        glCompileShader(shader);
        program = glCreateProgram();
        glAttachShader(program, shader);
        glLinkProgram(program);
        glDeleteShader(shader);
        glCreateSamplers(1, &sampler);
    }
    ~HostGl() {
        glDeleteProgram(program);
        glDeleteSamplers(1, &sampler);
    }

    void makeStateUnusual() const {
        glBindFramebuffer(GL_DRAW_FRAMEBUFFER, framebuffer.id());
        glBindFramebuffer(GL_READ_FRAMEBUFFER, readFramebuffer.id());
        glUseProgram(program);
        glBindVertexArray(vertexArray.id());
        glBindBuffer(GL_ARRAY_BUFFER, buffer.id());
        glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, buffer.id()); // VAO state
        for (GLuint i = 0; i < 5; ++i) glBindBufferRange(GL_SHADER_STORAGE_BUFFER, i, buffer.id(), 256 * i, 256);
        glBindBufferBase(GL_UNIFORM_BUFFER, 0, buffer.id());
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, 0);
        for (GLuint u = 0; u < 10; ++u) glBindTextureUnit(u, other.id());
        glBindSampler(1, sampler);
        glActiveTexture(GL_TEXTURE3);
        glBindImageTexture(0, other.id(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_RGBA8);
        glViewport(3, 5, 100, 50);
        glScissor(1, 2, 30, 40);
        glEnable(GL_SCISSOR_TEST);
        glEnable(GL_BLEND);
        glBlendFunc(GL_SRC_ALPHA, GL_ONE);
        glBlendEquation(GL_MAX);
        glEnable(GL_DEPTH_TEST);
        glDepthFunc(GL_GEQUAL);
        glDepthMask(GL_FALSE);
        glEnable(GL_CULL_FACE);
        glCullFace(GL_FRONT);
        glFrontFace(GL_CW);
        glColorMask(GL_TRUE, GL_FALSE, GL_TRUE, GL_TRUE);
        glClearColor(0.25f, 0.5f, 0.75f, 1.0f);
        glPixelStorei(GL_PACK_ALIGNMENT, 2);
        glPixelStorei(GL_UNPACK_ALIGNMENT, 8);
        glPixelStorei(GL_UNPACK_ROW_LENGTH, 7);
    }
};

/// Back to GL's defaults (the next test and the session's own assumptions start from them).
void resetState() {
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glUseProgram(0);
    glBindVertexArray(0);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
    for (GLuint i = 0; i < 8; ++i) glBindBufferBase(GL_SHADER_STORAGE_BUFFER, i, 0);
    glBindBufferBase(GL_UNIFORM_BUFFER, 0, 0);
    for (GLuint u = 0; u < 12; ++u) {
        glBindTextureUnit(u, 0);
        glBindSampler(u, 0);
    }
    glActiveTexture(GL_TEXTURE0);
    glBindImageTexture(0, 0, 0, GL_FALSE, 0, GL_READ_ONLY, GL_RGBA8);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_BLEND);
    glBlendFunc(GL_ONE, GL_ZERO);
    glBlendEquation(GL_FUNC_ADD);
    glDisable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    glDisable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glFrontFace(GL_CCW);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glClearColor(0, 0, 0, 0);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
}

cv::Mat readRgba(const gl::Texture& texture, int w, int h) {
    cv::Mat out(h, w, CV_8UC4);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glGetTextureImage(texture.id(), 0, GL_RGBA, GL_UNSIGNED_BYTE, GLsizei(out.total() * 4), out.data);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    cv::flip(out, out, 0); // GL row 0 is the bottom: top row first like the camera image
    return out;
}

class SessionGLTest : public test::GlTest {};

TEST_F(SessionGLTest, LeavesTheHostsGlStateAsItFoundIt) {
    auto session = sourceSession();
    HostGl host(session->camera().width, session->camera().height);
    host.makeStateUnusual();
    const StateRecord before = recordState();
    ASSERT_TRUE(session->processNext());
    mr::RenderTarget target;
    target.framebuffer = host.framebuffer.id();
    target.depthTest = true;
    session->render(target);
    target = {};
    target.texture = host.colour.id();
    target.content = mr::RenderContent::CompositeOverCamera;
    session->render(target);
    const StateRecord after = recordState();
    EXPECT_EQ(differences(before, after), "");
    // The record would see a leak: changing one binding is reported.
    glBindVertexArray(0);
    EXPECT_NE(differences(before, recordState()), "");
    resetState();
}

TEST_F(SessionGLTest, RendersUprightExactlyWhereTheVirtualContentIs) {
    // Placement only: the differential composite (on by default) also changes real pixels around
    // the objects, by design; tests/apps/DifferentialPipelineTest covers that.
    mr::SessionOptions options;
    options.pipeline.differential = false;
    auto session = sourceSession(options);
    ASSERT_TRUE(session->processNext());
    const int w = session->camera().width, h = session->camera().height;
    ASSERT_GT(session->report().coveredPixels, 500) << "the orbit's first frame sees the bunny and the cube";
    gl::Texture target = gl::Texture::create2D(GL_RGBA8, w, h);
    const float clear[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    glClearTexImage(target.id(), 0, GL_RGBA, GL_FLOAT, clear);
    mr::RenderTarget virtualOnly;
    virtualOnly.texture = target.id();
    session->render(virtualOnly);
    const cv::Mat drawn = readRgba(target, w, h);
    cv::Mat alpha;
    cv::extractChannel(drawn, alpha, 3);
    // Every covered pixel gets alpha 1 and no other pixel is touched.
    EXPECT_EQ(cv::countNonZero(alpha == 255), session->report().coveredPixels);
    EXPECT_EQ(cv::countNonZero(alpha), session->report().coveredPixels);

    // The composite: bit for bit the CPU composite, top row first.
    session->render({.texture = target.id(), .content = mr::RenderContent::CompositeOverCamera});
    cv::Mat composite;
    cv::cvtColor(readRgba(target, w, h), composite, cv::COLOR_RGBA2BGR);
    EXPECT_EQ(cv::norm(composite, session->output().withGi, cv::NORM_INF), 0.0);

    // Orientation: where the composite differs from the camera image, virtual content was drawn
    // (a flipped render would put the alpha elsewhere).
    auto source = capture::openFrameSource(recording(), {});
    RgbdFrame frame;
    ASSERT_TRUE(source->next(frame));
    cv::Mat changed;
    cv::Mat difference;
    cv::absdiff(session->output().withGi, frame.colour, difference);
    cv::cvtColor(difference, changed, cv::COLOR_BGR2GRAY);
    const int changedPixels = cv::countNonZero(changed);
    ASSERT_GT(changedPixels, 100);
    EXPECT_EQ(cv::countNonZero(changed & (alpha == 0)), 0) << "changed pixels outside the virtual-only render";
}

/// Two runs of one frame are not bit-identical: the VAL generator appends VALs with an atomic
/// counter, so their order (and the float summation order of the gather) changes from run to run.
/// Float sums over N ~ 4000 VALs change by ~sqrt(N) * 6e-8 ~ 4e-6 relative, i.e. <= 1e-3 code
/// values at 255: a value flips by one code only when it lies within that of a rounding boundary,
/// probability ~2e-3 per channel value, ~7 expected over the ~1200 covered pixels x 3 channels.
/// Allowed: at most 1 code value, in at most 1 % of the covered pixels' channel values (5x the
/// expectation and more; a swapped channel order, a lost stride or a wrong depth scale change
/// thousands of values by far more).
void expectSameUpToRunToRun(const cv::Mat& a, const cv::Mat& b, std::int64_t coveredPixels) {
    ASSERT_EQ(a.size(), b.size());
    EXPECT_LE(cv::norm(a, b, cv::NORM_INF), 1.0);
    cv::Mat difference;
    cv::absdiff(a, b, difference);
    EXPECT_LE(cv::countNonZero(difference.reshape(1)), std::max<std::int64_t>(1, 3 * coveredPixels / 100));
}

TEST_F(SessionGLTest, HostFramesGiveTheSameImageAsTheSource) {
    auto source = capture::openFrameSource(recording(), {});
    RgbdFrame frame;
    ASSERT_TRUE(source->next(frame));
    ASSERT_TRUE(frame.groundTruth_world_T_camera.has_value());
    auto reference = sourceSession();
    ASSERT_TRUE(reference->processNext());

    auto session = mr::Session::create({}, orbitScene(), frame.colourIntrinsics);
    const int w = frame.colour.cols, h = frame.colour.rows;
    // RGB rows with padding, depth rows with padding: the strides are honoured.
    cv::Mat rgbPadded(h, w * 3 + 16, CV_8UC1, cv::Scalar(255)), depthPadded(h, w + 8, CV_16UC1, cv::Scalar(1234));
    cv::Mat rgbView(h, w, CV_8UC3, rgbPadded.data, rgbPadded.step);
    cv::cvtColor(frame.colour, rgbView, cv::COLOR_BGR2RGB);
    frame.depth.copyTo(depthPadded(cv::Rect(0, 0, w, h)));
    mr::HostFrame host;
    host.rgb = rgbPadded.data;
    host.rgbRowBytes = rgbPadded.step;
    host.depth = depthPadded.ptr<std::uint16_t>();
    host.depthRowBytes = depthPadded.step;
    host.depthScaleMetres = frame.depthScaleMetres;
    host.intrinsics = frame.colourIntrinsics;
    host.timestampSeconds = 12.5;
    host.world_T_camera = frame.groundTruth_world_T_camera;
    session->submit(host);
    EXPECT_EQ(session->report().timestampSeconds, 12.5);
    EXPECT_EQ(session->report().trackingState, tracking::TrackingState::Tracking);
    EXPECT_EQ(session->report().valCount, reference->report().valCount);
    EXPECT_GT(session->report().valCount, 0u);
    expectSameUpToRunToRun(session->output().withGi, reference->output().withGi, reference->report().coveredPixels);

    // Bad input names the frame and the cause; the session stays usable.
    mr::HostFrame wrong = host;
    wrong.intrinsics.fx += 1.0;
    try {
        session->submit(wrong);
        ADD_FAILURE() << "no error for wrong intrinsics";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("intrinsics"), std::string::npos) << error.what();
        EXPECT_NE(std::string(error.what()).find("frame 1"), std::string::npos) << error.what();
    }
    wrong = host;
    wrong.rgb = nullptr;
    EXPECT_THROW(session->submit(wrong), Error);
    session->submit(host);
    expectSameUpToRunToRun(session->output().withGi, reference->output().withGi, reference->report().coveredPixels);
}

TEST_F(SessionGLTest, BadScenesAndTargetsAreErrors) {
    EXPECT_THROW(sourceSession({}, mr::SceneInput::fromJson("{\"version\": 1, \"objects\": 3}", ".")), Error);
    EXPECT_THROW(sourceSession({}, mr::SceneInput::fromFile("/nonexistent/scene.json")), Error);
    // A bad /tracking is the scene's error under every pose mode, not only when tracking reads it; a tag world
    // file that does not exist yet is an error only when the pose comes from the tags.
    const auto errorOf = [](mr::PoseMode pose, const std::string& sceneJson) -> std::string {
        mr::SessionOptions options;
        options.pipeline.poseMode = pose;
        try {
            sourceSession(options, mr::SceneInput::fromJson(sceneJson, "."));
        } catch (const Error& e) {
            return e.what();
        }
        return "accepted";
    };
    const std::string missingWorld = R"({"version": 1, "tracking": {"file": "no-such-tag-world.json"}})";
    const std::string badOption =
        R"({"version": 1, "tracking": {"file": "no-such-tag-world.json", "useDepth": "yes"}})";
    for (const mr::PoseMode pose : {mr::PoseMode::GroundTruth, mr::PoseMode::Fixed, mr::PoseMode::Tracking}) {
        SCOPED_TRACE(mr::toString(pose));
        EXPECT_NE(errorOf(pose, badOption).find("/tracking/useDepth"), std::string::npos);
        const std::string missing = errorOf(pose, missingWorld);
        if (pose == mr::PoseMode::Tracking)
            EXPECT_NE(missing.find("/tracking/file"), std::string::npos) << missing;
        else
            EXPECT_EQ(missing, "accepted");
        // The same for /roomModel: checked whatever the pose mode, though only tracking uses it (with tracking,
        // this scene's missing /tracking is said first).
        const std::string badRoom = errorOf(pose, R"({"version": 1, "roomModel": {"voxelSizeMetres": 0}})");
        const char* expectedKey = pose == mr::PoseMode::Tracking ? "/tracking" : "/roomModel/voxelSizeMetres";
        EXPECT_NE(badRoom.find(expectedKey), std::string::npos) << badRoom;
    }
    auto session = sourceSession();
    ASSERT_TRUE(session->processNext());
    EXPECT_THROW(session->render({.texture = 987654}), Error);
    EXPECT_THROW(session->render({.framebuffer = 0, .nearMetres = 1.0, .farMetres = 0.5}), Error);
}

// ---- gi.backend "auto": chosen once, by the GL renderer ----

TEST_F(SessionGLTest, BackendAutoIsTheCpuOnASoftwareRasterizerAndSaysWhy) {
    const auto* name = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    ASSERT_NE(name, nullptr);
    const std::string renderer(name);
    // The test's own reading of the renderers this suite runs on: Mesa's software rasterizers (CI: llvmpipe).
    bool software = false;
    for (const char* mesaSoftware : {"llvmpipe", "softpipe", "Software Rasterizer"})
        software = software || renderer.find(mesaSoftware) != std::string::npos;
    const gi::BackendChoice autoChoice =
        software ? gi::BackendChoice{gi::Backend::Cpu, gi::BackendReason::SoftwareRasterizer}
                 : gi::BackendChoice{gi::Backend::Gl, gi::BackendReason::Gpu};
    SCOPED_TRACE(renderer);

    auto session = sourceSession({}, orbitScene(256, nullptr)); // no gi.backend: the default
    mr::FramePipeline& pipeline = session->pipeline();
    EXPECT_EQ(pipeline.giSettings().backend, gi::BackendSetting::Auto); // kept as the scene gave it
    EXPECT_EQ(pipeline.backendChoice(), autoChoice);
    EXPECT_EQ(pipeline.backend(), autoChoice.backend); // the technique that runs
    EXPECT_EQ(pipeline.techniqueName(), software ? "lightskin-cpu" : "lightskin");
    ASSERT_TRUE(session->processNext());
    EXPECT_EQ(session->report().backend, autoChoice.backend);
    EXPECT_GT(session->report().valCount, 0u);

    // A frame budget's brute force runs on gl, which the reason says; back on LightSkin, auto chooses again.
    render::GiSettings gi = pipeline.giSettings();
    gi.technique = gi::Technique::BruteForce;
    pipeline.setGiSettings(gi);
    EXPECT_EQ(pipeline.backendChoice(), (gi::BackendChoice{gi::Backend::Gl, gi::BackendReason::TechniqueRunsOnlyOnGl}));
    EXPECT_EQ(pipeline.backend(), gi::Backend::Gl);
    gi.technique = gi::Technique::LightSkin;
    pipeline.setGiSettings(gi);
    EXPECT_EQ(pipeline.backendChoice(), autoChoice);
    EXPECT_EQ(pipeline.backend(), autoChoice.backend);

    // The scene's backend and the override win over auto, each named as the reason.
    EXPECT_EQ(sourceSession({}, orbitScene(256, "gl"))->pipeline().backendChoice(),
              (gi::BackendChoice{gi::Backend::Gl, gi::BackendReason::SceneSetting}));
    mr::SessionOptions overridden;
    overridden.pipeline.backend = gi::BackendSetting::Gl;
    auto onGl = sourceSession(overridden, orbitScene(256, "cpu"));
    EXPECT_EQ(onGl->pipeline().backendChoice(), (gi::BackendChoice{gi::Backend::Gl, gi::BackendReason::CommandLine}));
    EXPECT_EQ(onGl->pipeline().backend(), gi::Backend::Gl);
    overridden.pipeline.backend = gi::BackendSetting::Auto;
    EXPECT_EQ(sourceSession(overridden, orbitScene(256, "gl"))->pipeline().backendChoice(), autoChoice);
}

// ---- Frame budget on the steady recording, with an injected cost model ----

/// The test's machine: per technique a cost per interaction (LightSkin 3x, brute force 0.4x the
/// prior, i.e. the prior is wrong by both), a fixed GI overhead the model lacks, and +-2 %
/// deterministic alternating noise on the GI stage.
struct InjectedCosts {
    double jitter = 0.02;
    mutable int frame = 0;
    static double units(const mr::QualitySettings& c, const mr::FrameStats& s, int objects) {
        const double vals = s.vals * double(s.valStride * s.valStride) / double(c.valStride * c.valStride);
        if (c.technique == mr::Technique::BruteForce) return s.coveredPixels * vals * (c.glossy ? 1.5 : 1.0);
        const double points = double(c.sparsePoints) * objects;
        return points * vals * (c.glossy ? 1.5 : 1.0) + (c.occlusion ? 1.8 * points * points : 0.0) +
               2.6 * s.coveredPixels;
    }
    static double giMs(const mr::QualitySettings& c, const mr::FrameStats& s) {
        return 2.0 + (c.technique == mr::Technique::LightSkin ? 3.0e-5 : 0.4 * 8.2e-6) * units(c, s, 2);
    }
};

TEST_F(SessionGLTest, FrameBudgetIsMetOnASteadyRecordingAfterWarmUp) {
    constexpr double kBudgetMs = 150.0, kOtherMs = 7.0, kJitter = 0.02;
    mr::SessionOptions options;
    options.budgetMs = kBudgetMs;
    options.budget.sparsePointChoices = {256, 1024}; // keeps the real frames fast on llvmpipe
    options.budget.valStrideChoices = {4, 8};
    int calls = 0;
    options.costMeter = [&calls](const mr::QualitySettings& c, const mr::FrameStats& s, const mr::FrameOutput&) {
        const double noise = (calls++ % 2 == 0) ? 1.0 + kJitter : 1.0 - kJitter;
        return mr::StageCosts{InjectedCosts::giMs(c, s) * noise, kOtherMs};
    };
    auto session = sourceSession(options, orbitScene(1024));
    ASSERT_NE(session->budget(), nullptr);
    EXPECT_TRUE(session->budget()->needs().glossy) << "the cube is glossy";
    EXPECT_TRUE(session->budget()->needs().occlusion) << "two objects";

    constexpr int kFrames = 8, kWarmUp = 4;
    std::vector<mr::FrameStats> stats;
    std::vector<mr::QualitySettings> ran;
    for (int f = 0; f < kFrames; ++f) {
        ASSERT_TRUE(session->processNext());
        const mr::FrameReport& r = session->report();
        ASSERT_TRUE(r.budgetActive);
        EXPECT_EQ(r.budgetMs, kBudgetMs);
        ASSERT_GT(r.valCount, 0u);
        stats.push_back({double(r.valCount), r.settings.valStride, double(r.coveredPixels)});
        ran.push_back(r.settings);
        // Reported per frame: what the pipeline ran.
        EXPECT_EQ(applyTo(r.settings, session->pipeline().giSettings()).technique,
                  session->pipeline().giSettings().technique);
        EXPECT_EQ(r.settings.valStride, session->pipeline().giSettings().valStride);
    }
    // Tolerance: the budget predicts a frame from the previous frame's counts and its measured cost
    // per unit (blended over frames whose noise alternates +-j), so a frame that fits the prediction
    // costs at most budget * (1 + j) / (1 - j) * (growth of the units from one frame to the next),
    // the growth measured here on the recording (the orbit changes coverage and VALs smoothly).
    double growth = 1.0;
    for (int f = kWarmUp; f < kFrames; ++f)
        growth = std::max(growth, InjectedCosts::units(ran[std::size_t(f)], stats[std::size_t(f)], 2) /
                                      InjectedCosts::units(ran[std::size_t(f)], stats[std::size_t(f - 1)], 2));
    const double tolerance = (1.0 + kJitter) / (1.0 - kJitter) * growth;
    for (int f = kWarmUp; f < kFrames; ++f) {
        const double trueMs = InjectedCosts::giMs(ran[std::size_t(f)], stats[std::size_t(f)]) + kOtherMs;
        EXPECT_LE(trueMs, kBudgetMs * tolerance) << "frame " << f << ": " << describe(ran[std::size_t(f)]);
    }
    // The budget did work: the scene's own settings (1024 points, stride 4, glossy + occlusion)
    // cost far more than the budget on this machine.
    const mr::QualitySettings sceneDefault{mr::Technique::LightSkin, 1024, 4, true, true};
    EXPECT_GT(InjectedCosts::giMs(sceneDefault, stats.back()) + kOtherMs, 2.0 * kBudgetMs);
}

// ---- Prefetch (SessionOptions::prefetch): frame n+1's capture, filter and pose on a worker ----

/// The orbit scene on the CPU backend: its VALs come from the CPU generator in raster order and its
/// gather is independent of the thread count, so two runs of a frame are bit-identical (unlike the GL
/// path, see expectSameUpToRunToRun) and the prefetching run can be held to the sequential one exactly.
mr::SceneInput orbitSceneOnCpu() {
    mr::SceneInput scene = orbitScene(256, "cpu");
    // The tracker resolves its tag world against the scene file's folder, which an in-memory scene has not.
    const std::string world = "../synth-orbit/synth/tag-world.json";
    const auto worldAt = scene.json.find(world);
    EXPECT_NE(worldAt, std::string::npos);
    scene.json.replace(worldAt, world.size(), (recording() / "synth" / "tag-world.json").string());
    return scene;
}

mr::SessionOptions trackingOptions(bool prefetch) {
    mr::SessionOptions options;
    options.pipeline.poseMode = mr::PoseMode::Tracking; // the tracker's temporal state makes the order matter
    options.prefetch = prefetch;
    return options;
}

TEST_F(SessionGLTest, PrefetchGivesTheSequentialImagesBitForBit) {
    auto sequential = sourceSession(trackingOptions(false), orbitSceneOnCpu());
    auto prefetching = sourceSession(trackingOptions(true), orbitSceneOnCpu());
    constexpr int kFrames = 6; // tracking from the first frame, the filter's history, the worker's ring wrapped twice
    int tracked = 0;
    for (int f = 0; f < kFrames; ++f) {
        ASSERT_TRUE(sequential->processNext());
        ASSERT_TRUE(prefetching->processNext());
        const mr::FrameOutput &a = sequential->output(), &b = prefetching->output();
        ASSERT_EQ(prefetching->sourceFrame().index, f) << "the frame the output belongs to";
        EXPECT_EQ(cv::norm(sequential->sourceFrame().colour, prefetching->sourceFrame().colour, cv::NORM_INF), 0.0);
        ASSERT_EQ(a.world_T_camera.has_value(), b.world_T_camera.has_value()) << "frame " << f;
        if (a.world_T_camera) {
            ++tracked;
            EXPECT_EQ(a.world_T_camera->matrix(), b.world_T_camera->matrix()) << "frame " << f;
        }
        EXPECT_EQ(a.tracking.state, b.tracking.state) << "frame " << f;
        EXPECT_EQ(a.valCount, b.valCount) << "frame " << f;
        ASSERT_EQ(a.withGi.size(), b.withGi.size());
        EXPECT_EQ(cv::norm(a.withGi, b.withGi, cv::NORM_INF), 0.0) << "frame " << f << ": not bit for bit";
        EXPECT_EQ(cv::norm(a.linearWithGi, b.linearWithGi, cv::NORM_INF), 0.0) << "frame " << f;
        // Not a test of two empty images: GI lit the objects, and they cover part of the frame; the differential,
        // which the prefetching session runs beside the GI, changed real pixels.
        EXPECT_TRUE(b.giActive) << "frame " << f;
        EXPECT_GT(b.coveredPixels, 100) << "frame " << f;
        EXPECT_EQ(a.differentialPixels, b.differentialPixels) << "frame " << f;
        if (b.world_T_camera) {
            EXPECT_GT(b.differentialPixels, 100) << "frame " << f;
        }
    }
    EXPECT_GE(tracked, kFrames - 1) << "the tags are seen in the recording's first frames";
}

/// The recording, with a read error at frame `failAt`.
class FailingSource : public capture::FrameSource {
public:
    FailingSource(std::unique_ptr<capture::FrameSource> inner, std::int64_t failAt)
        : FrameSource(inner->info(), inner->options())
        , inner_(std::move(inner))
        , failAt_(failAt) {}

protected:
    bool readNext(RgbdFrame& out) override {
        if (inner_->framesDelivered() == failAt_) throw Error("fake.oni", failAt_, "truncated frame");
        return inner_->next(out);
    }

private:
    std::unique_ptr<capture::FrameSource> inner_;
    std::int64_t failAt_;
};

TEST_F(SessionGLTest, PrefetchReportsASourceErrorAtItsFrame) {
    constexpr std::int64_t kFailAt = 3;
    auto session =
        mr::Session::create(trackingOptions(true), orbitSceneOnCpu(),
                            std::make_unique<FailingSource>(capture::openFrameSource(recording(), {}), kFailAt));
    for (std::int64_t f = 0; f < kFailAt; ++f) {
        ASSERT_TRUE(session->processNext()) << "frame " << f << " comes before the error";
        EXPECT_EQ(session->sourceFrame().index, f);
    }
    for (int attempt = 0; attempt < 2; ++attempt) { // the worker stopped at the error: it stays
        try {
            session->processNext();
            ADD_FAILURE() << "no error for the failing frame";
        } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find("fake.oni"), std::string::npos) << error.what();
            EXPECT_NE(std::string(error.what()).find("frame 3"), std::string::npos) << error.what();
            EXPECT_NE(std::string(error.what()).find("truncated frame"), std::string::npos) << error.what();
        }
    }
    EXPECT_EQ(session->report().frameIndex, kFailAt - 1) << "the last frame that rendered";
}

// ---- GI ahead (FramePipeline::render with the prefetch's next frame): frame n+1's CPU VALs and stages 0-4 ----
// ---- computed while frame n reads back and composites ----

void expectSameFrame(const mr::FrameOutput& a, const mr::FrameOutput& b, int f) {
    EXPECT_EQ(a.valCount, b.valCount) << "frame " << f;
    ASSERT_EQ(a.withGi.size(), b.withGi.size()) << "frame " << f;
    EXPECT_EQ(cv::norm(a.withGi, b.withGi, cv::NORM_INF), 0.0) << "frame " << f << ": not bit for bit";
    EXPECT_EQ(cv::norm(a.linearWithGi, b.linearWithGi, cv::NORM_INF), 0.0) << "frame " << f;
    // Not a test of two empty images: GI lit the objects, and they cover part of the frame.
    EXPECT_TRUE(b.giActive) << "frame " << f;
    EXPECT_GT(b.coveredPixels, 100) << "frame " << f;
    EXPECT_GT(b.valCount, 100u) << "frame " << f;
    EXPECT_EQ(a.differentialPixels, b.differentialPixels) << "frame " << f;
    EXPECT_GT(b.differentialPixels, 100) << "frame " << f << ": the differential ran";
}

// The prefetching session computes each frame's GI during the frame before (giComputedAhead), and its images
// equal the sequential session's bit for bit, also when the GI settings change between two frames: the GI
// computed ahead under the old settings must be dropped and the frame's own computed instead.
TEST_F(SessionGLTest, GiAheadGivesTheSequentialImagesBitForBitAcrossASettingsChange) {
    auto sequential = sourceSession(trackingOptions(false), orbitSceneOnCpu());
    auto prefetching = sourceSession(trackingOptions(true), orbitSceneOnCpu());
    constexpr int kFrames = 6, kChangeAt = 3;
    bool trackedBefore = false;
    for (int f = 0; f < kFrames; ++f) {
        if (f == kChangeAt)
            for (mr::Session* session : {sequential.get(), prefetching.get()}) {
                render::GiSettings gi = session->pipeline().giSettings();
                gi.glossy = !gi.glossy;
                session->pipeline().setGiSettings(gi);
            }
        ASSERT_TRUE(sequential->processNext());
        ASSERT_TRUE(prefetching->processNext());
        const mr::FrameOutput &a = sequential->output(), &b = prefetching->output();
        ASSERT_EQ(prefetching->sourceFrame().index, f) << "the frame the output belongs to";
        ASSERT_EQ(a.world_T_camera.has_value(), b.world_T_camera.has_value()) << "frame " << f;
        ASSERT_TRUE(b.world_T_camera.has_value()) << "frame " << f << ": the tags are seen in the first frames";
        expectSameFrame(a, b, f);
        EXPECT_FALSE(a.giComputedAhead) << "frame " << f << ": the sequential session has no next frame";
        // Ahead when the frame before ran GI (frame 0 has none before it), except after the change.
        EXPECT_EQ(b.giComputedAhead, trackedBefore && f != kChangeAt) << "frame " << f;
        trackedBefore = true;
    }
}

/// The recording with frame `badAt`'s colour as BGRA: its depth filter and ground-truth pose work, its CPU
/// VALs do not (gi::CpuValGenerator needs BGR), so the error comes from the stage the GI ahead runs early.
class BgraColourSource : public capture::FrameSource {
public:
    BgraColourSource(std::unique_ptr<capture::FrameSource> inner, std::int64_t badAt)
        : FrameSource(inner->info(), inner->options())
        , inner_(std::move(inner))
        , badAt_(badAt) {}

protected:
    bool readNext(RgbdFrame& out) override {
        const std::int64_t index = inner_->framesDelivered();
        if (!inner_->next(out)) return false;
        if (index == badAt_) cv::cvtColor(out.colour, out.colour, cv::COLOR_BGR2BGRA);
        return true;
    }

private:
    std::unique_ptr<capture::FrameSource> inner_;
    std::int64_t badAt_;
};

// A frame whose VALs fail: the GI ahead meets the error while the frame before renders; that frame must still
// come out whole, and the error must be thrown for its own frame, as in the sequential session; the frame
// after it renders again. Ground-truth poses (the tracker would not take the BGRA image).
TEST_F(SessionGLTest, GiAheadReportsAValErrorAtItsFrame) {
    constexpr std::int64_t kBadAt = 2, kFrames = 4;
    std::unique_ptr<mr::Session> sessions[2];
    for (int prefetch = 0; prefetch < 2; ++prefetch) {
        mr::SessionOptions options;
        options.prefetch = prefetch == 1;
        sessions[prefetch] =
            mr::Session::create(options, orbitSceneOnCpu(),
                                std::make_unique<BgraColourSource>(capture::openFrameSource(recording(), {}), kBadAt));
    }
    for (std::int64_t f = 0; f < kFrames; ++f) {
        for (auto& session : sessions) {
            if (f != kBadAt) {
                ASSERT_TRUE(session->processNext()) << "frame " << f;
                EXPECT_EQ(session->report().frameIndex, f);
                continue;
            }
            try {
                session->processNext();
                ADD_FAILURE() << "no error for frame " << f;
            } catch (const Error& error) {
                EXPECT_NE(std::string(error.what()).find("CV_8UC3"), std::string::npos) << error.what();
            }
            EXPECT_EQ(session->report().frameIndex, kBadAt - 1) << "the last frame that rendered";
        }
        if (f != kBadAt) expectSameFrame(sessions[0]->output(), sessions[1]->output(), int(f));
        if (f == 1) {
            EXPECT_TRUE(sessions[1]->output().giComputedAhead) << "the GI ahead ran before the bad frame";
        }
    }
}

} // namespace
