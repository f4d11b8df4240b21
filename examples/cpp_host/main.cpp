// A C++ host: owns a headless EGL pbuffer surface (640x240) with a depth buffer, draws its own
// geometry, and lets lightskin add the lit virtual objects of a recording's frames, which the host
// reads itself and submits from its own memory with its own pose; it turns the first object a little
// every frame (Session::setObjectTransform).
//   left half:  the host's scene -- a far backdrop and a near panel over the left third of the
//               view, drawn with the session's projection -- plus lightskin's virtual objects,
//               depth-tested against the host's depth (the panel hides them, the backdrop does not);
//   right half: lightskin's composite over the camera image.
// Checks: no virtual pixel shows through the near panel; behind the backdrop every covered pixel
// outside the panel shows; the right half equals the session's CPU composite.
//   cpp_host <recording folder> <scene file> [frames]                 prints "cpp_host ok"
#include <lightskin/capture/FrameSource.h>
#include <lightskin/mr/Session.h>

#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <vector>

namespace {

struct HostWindow { // what an engine's platform layer would own
    EGLDisplay display = EGL_NO_DISPLAY;
    EGLSurface surface = EGL_NO_SURFACE;
    EGLContext context = EGL_NO_CONTEXT;
    HostWindow(int w, int h) {
        display = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
        if (display == EGL_NO_DISPLAY || !eglInitialize(display, nullptr, nullptr))
            throw std::runtime_error("no EGL display");
        const EGLint configAttributes[] = {EGL_RENDERABLE_TYPE,
                                           EGL_OPENGL_BIT,
                                           EGL_SURFACE_TYPE,
                                           EGL_PBUFFER_BIT,
                                           EGL_RED_SIZE,
                                           8,
                                           EGL_GREEN_SIZE,
                                           8,
                                           EGL_BLUE_SIZE,
                                           8,
                                           EGL_DEPTH_SIZE,
                                           24,
                                           EGL_NONE};
        EGLConfig config;
        EGLint count = 0;
        if (!eglBindAPI(EGL_OPENGL_API) || !eglChooseConfig(display, configAttributes, &config, 1, &count) || count < 1)
            throw std::runtime_error("no EGL config with depth");
        const EGLint surfaceAttributes[] = {EGL_WIDTH, w, EGL_HEIGHT, h, EGL_NONE};
        surface = eglCreatePbufferSurface(display, config, surfaceAttributes);
        const EGLint contextAttributes[] = {
            EGL_CONTEXT_MAJOR_VERSION,           4,       EGL_CONTEXT_MINOR_VERSION, 5, EGL_CONTEXT_OPENGL_PROFILE_MASK,
            EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
        context = eglCreateContext(display, config, EGL_NO_CONTEXT, contextAttributes);
        if (surface == EGL_NO_SURFACE || context == EGL_NO_CONTEXT ||
            !eglMakeCurrent(display, surface, surface, context))
            throw std::runtime_error("no OpenGL 4.5 core context on a pbuffer");
    }
    ~HostWindow() {
        eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        eglDestroyContext(display, context);
        eglDestroySurface(display, surface);
        eglTerminate(display);
    }
};

GLuint compile(GLenum stage, const char* source) {
    const GLuint shader = glCreateShader(stage);
    glShaderSource(shader, 1, &source, nullptr);
    glCompileShader(shader);
    return shader;
}

/// The host's own renderer: flat-coloured quads given in the camera frame (OpenCV axes, metres).
struct HostRenderer {
    GLuint program = 0, vertexArray = 0;
    HostRenderer() {
        const GLuint vs = compile(GL_VERTEX_SHADER, R"(#version 450 core
            uniform mat4 clip_T_camera;
            uniform vec4 rect; // x0, y0, x1, y1 in the plane z = depth
            uniform float depth;
            void main() {
                const vec2 corner = vec2(gl_VertexID & 1, (gl_VertexID >> 1) & 1);
                gl_Position = clip_T_camera * vec4(mix(rect.xy, rect.zw, corner), depth, 1.0);
            })");
        const GLuint fs = compile(GL_FRAGMENT_SHADER, R"(#version 450 core
            uniform vec3 colour;
            layout(location = 0) out vec4 fragment;
            void main() { fragment = vec4(colour, 1.0); })");
        program = glCreateProgram();
        glAttachShader(program, vs);
        glAttachShader(program, fs);
        glLinkProgram(program);
        glDeleteShader(vs);
        glDeleteShader(fs);
        glCreateVertexArrays(1, &vertexArray);
    }
    ~HostRenderer() {
        glDeleteProgram(program);
        glDeleteVertexArrays(1, &vertexArray);
    }
    void quad(const glm::mat4& clip_T_camera, glm::vec4 rect, float depth, glm::vec3 colour) const {
        glUseProgram(program);
        glUniformMatrix4fv(glGetUniformLocation(program, "clip_T_camera"), 1, GL_FALSE, glm::value_ptr(clip_T_camera));
        glUniform4fv(glGetUniformLocation(program, "rect"), 1, glm::value_ptr(rect));
        glUniform1f(glGetUniformLocation(program, "depth"), depth);
        glUniform3fv(glGetUniformLocation(program, "colour"), 1, glm::value_ptr(colour));
        glBindVertexArray(vertexArray);
        glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
    }
};

cv::Mat readBack(int x, int y, int w, int h) { // top row first, RGBA
    cv::Mat out(h, w, CV_8UC4);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(x, y, w, h, GL_RGBA, GL_UNSIGNED_BYTE, out.data);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    cv::flip(out, out, 0);
    return out;
}

int run(int argc, char** argv) {
    namespace mr = lightskin::mr;
    if (argc < 3) {
        std::fprintf(stderr, "usage: cpp_host <recording> <scene.json> [frames]\n");
        return 2;
    }
    const int frames = argc > 3 ? std::atoi(argv[3]) : 2;
    auto source = lightskin::capture::openFrameSource(argv[1], {}); // the host's own input
    const lightskin::CameraIntrinsics camera = source->info().colourIntrinsics;
    const int w = camera.width, h = camera.height;
    HostWindow window(2 * w, h);
    const HostRenderer host;
    auto session = mr::Session::create({}, mr::SceneInput::fromFile(argv[2]), camera);
    // The virtual objects alone (no depth test), to know where they are.
    GLuint coverage = 0;
    glCreateTextures(GL_TEXTURE_2D, 1, &coverage);
    glTextureStorage2D(coverage, 1, GL_RGBA8, w, h);

    constexpr double kNear = 0.05, kFar = 20.0;
    const float panelDepth = 0.3f, backdropDepth = 15.0f; // metres: in front of / behind the content
    const glm::vec3 panelColour(0.0f, 1.0f, 0.0f), backdropColour(0.0f, 0.0f, 1.0f);
    // The panel covers u < W/3: X/Z < (W/3 - cx) / fx.
    const float panelRight = float((w / 3.0 - camera.cx) / camera.fx) * panelDepth;
    lightskin::RgbdFrame frame;
    cv::Mat rgb;
    int failures = 0;
    const glm::mat4 start = session->scene().objects.at(0).world_T_model;
    for (int f = 0; f < frames && source->next(frame); ++f) {
        // The host moves the first object: it turns 5 degrees per frame about the world's z axis (up) in place.
        const glm::mat4 turn = glm::rotate(glm::mat4(1.0f), glm::radians(5.0f * float(f)), glm::vec3(0, 0, 1));
        glm::mat4 placement = turn * start;
        placement[3] = start[3]; // about the object's own origin
        session->setObjectTransform(0, placement);
        cv::cvtColor(frame.colour, rgb, cv::COLOR_BGR2RGB);
        mr::HostFrame submitted;
        submitted.rgb = rgb.data;
        submitted.rgbRowBytes = rgb.step;
        submitted.depth = frame.depth.ptr<std::uint16_t>();
        submitted.depthRowBytes = frame.depth.step;
        submitted.depthScaleMetres = frame.depthScaleMetres;
        submitted.intrinsics = camera;
        submitted.timestampSeconds = frame.colourTimestampSeconds;
        submitted.world_T_camera = frame.groundTruth_world_T_camera; // "the host's tracking"
        session->submit(submitted);

        // The host draws its frame.
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        glViewport(0, 0, w, h);
        glEnable(GL_DEPTH_TEST);
        glDepthFunc(GL_LESS);
        glClearColor(0.2f, 0.2f, 0.2f, 1.0f);
        glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
        const glm::mat4 projection = session->projection(kNear, kFar);
        host.quad(projection, glm::vec4(-100.0f, -100.0f, 100.0f, 100.0f), backdropDepth, backdropColour);
        host.quad(projection, glm::vec4(-10.0f, -10.0f, panelRight, 10.0f), panelDepth, panelColour);
        // lightskin adds the lit virtual objects (depth-tested) and the composite beside them.
        session->render({.framebuffer = 0, .depthTest = true, .nearMetres = kNear, .farMetres = kFar});
        session->render({.framebuffer = 0, .x = w, .content = mr::RenderContent::CompositeOverCamera});
        const float transparent[4] = {0.0f, 0.0f, 0.0f, 0.0f};
        glClearTexImage(coverage, 0, GL_RGBA, GL_FLOAT, transparent); // VirtualOnly leaves uncovered pixels as they are
        session->render({.texture = coverage});

        const cv::Mat left = readBack(0, 0, w, h), right = readBack(w, 0, w, h);
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        cv::Mat covered(h, w, CV_8UC4);
        glPixelStorei(GL_PACK_ALIGNMENT, 1);
        glGetTextureImage(coverage, 0, GL_RGBA, GL_UNSIGNED_BYTE, int(covered.total() * 4), covered.data);
        cv::flip(covered, covered, 0);
        int throughPanel = 0, shown = 0, hidden = 0, coveredOutside = 0;
        for (int v = 0; v < h; ++v)
            for (int u = 0; u < w; ++u) {
                const cv::Vec4b p = left.at<cv::Vec4b>(v, u);
                const bool isPanel = p == cv::Vec4b(0, 255, 0, 255), isBackdrop = p == cv::Vec4b(0, 0, 255, 255);
                const bool virtualHere = covered.at<cv::Vec4b>(v, u)[3] != 0;
                if (u < w / 3 - 1) throughPanel += !isPanel; // the panel's edge pixel may go either way
                if (u > w / 3 + 1 && virtualHere) {
                    ++coveredOutside;
                    shown += !isBackdrop;
                    hidden += isBackdrop;
                }
            }
        cv::Mat composite;
        cv::cvtColor(right, composite, cv::COLOR_RGBA2BGR);
        const double compositeError = cv::norm(composite, session->output().withGi, cv::NORM_INF);
        const mr::FrameReport& r = session->report();
        std::printf(
            "frame %lld: %u VALs, %lld covered, %d covered right of the panel: %d shown, %d hidden; %d panel pixels "
            "overdrawn; composite max error %.0f; %s, %.0f ms\n",
            static_cast<long long>(r.frameIndex), r.valCount, static_cast<long long>(r.coveredPixels), coveredOutside,
            shown, hidden, throughPanel, compositeError, mr::describe(r.settings).c_str(), r.totalMs);
        if (throughPanel != 0 || hidden != 0 || coveredOutside == 0 || compositeError != 0.0 || r.valCount == 0)
            ++failures;
    }
    glDeleteTextures(1, &coverage);
    session.reset(); // before the context goes
    if (failures != 0) {
        std::fprintf(stderr, "cpp_host: %d frame(s) failed the checks\n", failures);
        return 1;
    }
    std::printf("cpp_host ok\n");
    return 0;
}

} // namespace

int main(int argc, char** argv) {
    try {
        return run(argc, argv);
    } catch (const std::exception& error) {
        std::fprintf(stderr, "cpp_host: %s\n", error.what());
        return 1;
    }
}
