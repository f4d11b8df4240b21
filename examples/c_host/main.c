/* A C host: creates its own headless OpenGL 4.5 context (EGL, surfaceless) and framebuffer, runs
 * a recording through lightskin's C ABI and lets it draw the lit virtual objects into that
 * framebuffer, sliding the first object 1 cm per frame (lsk_session_set_object_transform). Checks that the result is
 * not trivial: the pixels that changed are exactly those the virtual content covers (as the frame report counts them),
 * the host's framebuffer binding and viewport are as the host left them, and bad input is an error code with a message.
 *   c_host <recording folder> <scene file> [frames]                   prints "c_host ok" */
#include <epoxy/egl.h>
#include <epoxy/gl.h>

#include <lightskin.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int fail(const char* what) {
    fprintf(stderr, "c_host: %s%s%s\n", what, lsk_last_error()[0] ? ": " : "", lsk_last_error());
    return 1;
}

static EGLDisplay display = EGL_NO_DISPLAY;
static EGLContext context = EGL_NO_CONTEXT;

/* A GL 4.5 core context without a window: the host owns it. */
static int createContext(void) {
    display = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL);
    if (display == EGL_NO_DISPLAY || !eglInitialize(display, NULL, NULL)) return 0;
    const EGLint configAttributes[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, EGL_PBUFFER_BIT,
                                       EGL_NONE};
    EGLConfig config;
    EGLint count = 0;
    if (!eglBindAPI(EGL_OPENGL_API) || !eglChooseConfig(display, configAttributes, &config, 1, &count) || count < 1)
        return 0;
    const EGLint contextAttributes[] = {
        EGL_CONTEXT_MAJOR_VERSION,           4,       EGL_CONTEXT_MINOR_VERSION, 5, EGL_CONTEXT_OPENGL_PROFILE_MASK,
        EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
    context = eglCreateContext(display, config, EGL_NO_CONTEXT, contextAttributes);
    return context != EGL_NO_CONTEXT && eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context);
}

int main(int argc, char** argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: c_host <recording> <scene.json> [frames]\n");
        return 2;
    }
    const int frames = argc > 3 ? atoi(argv[3]) : 3;
    printf("lightskin %s (header %d.%d.%d)\n", lsk_version(), LSK_VERSION_MAJOR, LSK_VERSION_MINOR, LSK_VERSION_PATCH);
    if (!createContext()) {
        fprintf(stderr, "c_host: no EGL OpenGL 4.5 core context\n");
        return 1;
    }

    lsk_session_options options;
    lsk_session_options_init(&options);
    options.pose_mode = LSK_POSE_HOST; /* the recording's ground truth */
    lsk_scene scene;
    lsk_scene_init(&scene);
    scene.path = argv[2];
    lsk_session* session = NULL;

    /* Bad input: an error code and a message naming the cause, no crash. */
    if (lsk_session_create_from_source(&options, &scene, "/nonexistent/recording", &session) != LSK_ERROR_INPUT ||
        session != NULL || strlen(lsk_last_error()) == 0)
        return fail("a missing recording was not reported as LSK_ERROR_INPUT");
    printf("expected error: %s\n", lsk_last_error());

    if (lsk_session_create_from_source(&options, &scene, argv[1], &session) != LSK_OK)
        return fail("lsk_session_create_from_source");
    lsk_camera camera;
    if (lsk_session_camera(session, &camera) != LSK_OK) return fail("lsk_session_camera");

    /* The host's framebuffer: RGBA8 colour + depth. */
    GLuint colour = 0, depth = 0, framebuffer = 0;
    glCreateTextures(GL_TEXTURE_2D, 1, &colour);
    glTextureStorage2D(colour, 1, GL_RGBA8, camera.width, camera.height);
    glCreateRenderbuffers(1, &depth);
    glNamedRenderbufferStorage(depth, GL_DEPTH_COMPONENT32F, camera.width, camera.height);
    glCreateFramebuffers(1, &framebuffer);
    glNamedFramebufferTexture(framebuffer, GL_COLOR_ATTACHMENT0, colour, 0);
    glNamedFramebufferRenderbuffer(framebuffer, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth);
    if (glCheckNamedFramebufferStatus(framebuffer, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
        return fail("host framebuffer incomplete");
    unsigned char* pixels = malloc((size_t)camera.width * (size_t)camera.height * 4);
    if (pixels == NULL) return fail("out of memory");

    /* The host moves the first object: it slides 1 cm per frame along the world's x axis. */
    float start[16];
    if (lsk_session_object_transform(session, 0, start) != LSK_OK) return fail("lsk_session_object_transform");
    int status = 0;
    for (int f = 0; f < frames && status == 0; ++f) {
        float placement[16];
        memcpy(placement, start, sizeof placement);
        placement[12] += 0.01f * (float)f; /* column-major: the translation is elements 12..14 */
        if (lsk_session_set_object_transform(session, 0, placement) != LSK_OK)
            return fail("lsk_session_set_object_transform");
        const lsk_status next = lsk_session_process_next(session);
        if (next == LSK_END_OF_STREAM) break;
        if (next != LSK_OK) return fail("lsk_session_process_next");
        lsk_frame_report report;
        lsk_frame_report_init(&report);
        if (lsk_session_report(session, &report) != LSK_OK) return fail("lsk_session_report");

        /* The host's frame: cleared to a colour lightskin never writes (alpha 0), its own viewport. */
        glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
        glViewport(0, 0, camera.width, camera.height);
        glClearColor(0.0f, 0.0f, 0.0f, 0.0f);
        glClearDepth(1.0);
        glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);

        lsk_render_target target;
        lsk_render_target_init(&target);
        target.framebuffer = framebuffer;
        target.depth_test = 1;
        if (lsk_session_render(session, &target) != LSK_OK) return fail("lsk_session_render");

        GLint bound = 0, viewport[4] = {0, 0, 0, 0};
        glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &bound);
        glGetIntegerv(GL_VIEWPORT, viewport);
        if ((GLuint)bound != framebuffer || viewport[2] != camera.width || viewport[3] != camera.height)
            return fail("lightskin changed the host's framebuffer binding or viewport");

        glPixelStorei(GL_PACK_ALIGNMENT, 1);
        glReadPixels(0, 0, camera.width, camera.height, GL_RGBA, GL_UNSIGNED_BYTE, pixels);
        long changed = 0;
        for (long i = 0; i < (long)camera.width * camera.height; ++i) changed += pixels[4 * i + 3] != 0;
        printf("frame %lld: tracking %d, %u VALs, %lld covered pixels, %ld pixels drawn, %s sparse=%d stride=%d, %.1f "
               "ms\n",
               (long long)report.frame_index, report.tracking_state, report.val_count, (long long)report.covered_pixels,
               changed, report.technique == LSK_TECHNIQUE_LIGHTSKIN ? "lightskin" : "brute-force", report.sparse_points,
               report.val_stride, report.total_ms);
        /* Non-trivial: something was drawn, not everything, and exactly where the content is. */
        if (changed == 0 || changed != report.covered_pixels || changed == (long)camera.width * camera.height)
            status = 1;
        if (report.val_count == 0 || report.has_pose != 1) status = 1;
    }
    free(pixels);
    lsk_session_destroy(session);
    glDeleteFramebuffers(1, &framebuffer);
    glDeleteRenderbuffers(1, &depth);
    glDeleteTextures(1, &colour);
    /* The host ends what it began: a context still current at exit is torn down only partly by Mesa's
     * exit handler, and LeakSanitizer then reports the driver's context memory as leaked. */
    eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(display, context);
    eglTerminate(display);
    if (status != 0) return fail("the drawn pixels do not match the virtual content");
    printf("c_host ok\n");
    return 0;
}
