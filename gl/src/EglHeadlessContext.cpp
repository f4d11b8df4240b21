// Headless OpenGL through EGL. Platform order: Mesa surfaceless (no display server, no device
// file needed: llvmpipe in CI), then EGL devices (GPU drivers without a display), then the
// default display with a 1x1 pbuffer (old drivers).
#include <lightskin/core/Error.h>
#include <lightskin/core/LeakCheck.h>
#include <lightskin/core/Log.h>
#include <lightskin/gl/Context.h>

#include <epoxy/egl.h>

#include <array>
#include <cstring>
#include <vector>

namespace lightskin::gl {

namespace {

bool hasExtension(const char* extensions, const char* name) {
    if (!extensions) return false;
    const std::size_t length = std::strlen(name);
    for (const char* p = std::strstr(extensions, name); p; p = std::strstr(p + length, name))
        if ((p == extensions || p[-1] == ' ') && (p[length] == ' ' || p[length] == '\0')) return true;
    return false;
}

std::string eglErrorText(EGLint error) {
    char hex[16];
    std::snprintf(hex, sizeof hex, "0x%04X", unsigned(error));
    return hex;
}

class EglHeadlessContext final : public Context {
public:
    EglHeadlessContext(EGLDisplay display, EGLContext context, EGLSurface surface, std::string platform)
        : display_(display), context_(context), surface_(surface), platform_(std::move(platform)) {}
    ~EglHeadlessContext() override {
        eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        if (surface_ != EGL_NO_SURFACE) eglDestroySurface(display_, surface_);
        eglDestroyContext(display_, context_);
        eglTerminate(display_);
    }
    void makeCurrent() override {
        if (!eglMakeCurrent(display_, surface_, surface_, context_))
            throw Error(platform_, std::nullopt, "eglMakeCurrent failed: " + eglErrorText(eglGetError()));
    }
    std::string platformName() const override { return platform_; }
    void initialise(const ContextOptions& options) { finishInitialisation(options); }

private:
    EGLDisplay display_;
    EGLContext context_;
    EGLSurface surface_;
    std::string platform_;
};

struct Candidate {
    EGLDisplay display;
    std::string platform;
};

std::vector<Candidate> candidateDisplays() {
    std::vector<Candidate> candidates;
    const char* clientExtensions = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    const bool platformBase = hasExtension(clientExtensions, "EGL_EXT_platform_base") || epoxy_egl_version(EGL_NO_DISPLAY) >= 15;
    if (platformBase && hasExtension(clientExtensions, "EGL_MESA_platform_surfaceless")) {
        EGLDisplay display = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
        if (display != EGL_NO_DISPLAY) candidates.push_back({display, "egl-surfaceless"});
    }
    if (platformBase && hasExtension(clientExtensions, "EGL_EXT_platform_device") &&
        hasExtension(clientExtensions, "EGL_EXT_device_enumeration")) {
        std::array<EGLDeviceEXT, 8> devices{};
        EGLint count = 0;
        if (eglQueryDevicesEXT(EGLint(devices.size()), devices.data(), &count))
            for (EGLint i = 0; i < count; ++i) {
                EGLDisplay display = eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[std::size_t(i)], nullptr);
                if (display != EGL_NO_DISPLAY) candidates.push_back({display, "egl-device"});
            }
    }
    EGLDisplay fallback = eglGetDisplay(EGL_DEFAULT_DISPLAY);
    if (fallback != EGL_NO_DISPLAY) candidates.push_back({fallback, "egl-pbuffer"});
    return candidates;
}

} // namespace

std::unique_ptr<Context> createHeadlessContext(const ContextOptions& options) {
    std::string failures;
    for (const Candidate& candidate : candidateDisplays()) {
        EGLint major = 0, minor = 0;
        if (!eglInitialize(candidate.display, &major, &minor)) {
            failures += "\n  " + candidate.platform + ": eglInitialize failed (" + eglErrorText(eglGetError()) + ")";
            continue;
        }
        sanitizer::keepLoadedModulesMapped(); // the DRI driver, for LeakSanitizer's report at exit
        const bool needsSurface = candidate.platform == "egl-pbuffer" ||
                                  !hasExtension(eglQueryString(candidate.display, EGL_EXTENSIONS), "EGL_KHR_surfaceless_context");
        const EGLint configAttributes[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE,
                                           needsSurface ? EGL_PBUFFER_BIT : 0, EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8,
                                           EGL_BLUE_SIZE, 8, EGL_ALPHA_SIZE, 8, EGL_NONE};
        EGLConfig config = nullptr;
        EGLint configCount = 0;
        if (!eglBindAPI(EGL_OPENGL_API) || !eglChooseConfig(candidate.display, configAttributes, &config, 1, &configCount) ||
            configCount == 0) {
            failures += "\n  " + candidate.platform + ": no OpenGL-capable EGLConfig";
            eglTerminate(candidate.display);
            continue;
        }
        const EGLint contextAttributes[] = {EGL_CONTEXT_MAJOR_VERSION, options.versionMajor,
                                            EGL_CONTEXT_MINOR_VERSION, options.versionMinor,
                                            EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                            EGL_CONTEXT_OPENGL_DEBUG, options.debug ? EGL_TRUE : EGL_FALSE,
                                            EGL_NONE};
        EGLContext context = eglCreateContext(candidate.display, config, EGL_NO_CONTEXT, contextAttributes);
        if (context == EGL_NO_CONTEXT) {
            failures += "\n  " + candidate.platform + ": eglCreateContext(" + std::to_string(options.versionMajor) + "." +
                        std::to_string(options.versionMinor) + " core) failed (" + eglErrorText(eglGetError()) + ")";
            eglTerminate(candidate.display);
            continue;
        }
        EGLSurface surface = EGL_NO_SURFACE;
        if (needsSurface) {
            const EGLint pbufferAttributes[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
            surface = eglCreatePbufferSurface(candidate.display, config, pbufferAttributes);
        }
        auto result = std::make_unique<EglHeadlessContext>(candidate.display, context, surface, candidate.platform);
        try {
            result->makeCurrent();
            result->initialise(options);
        } catch (const Error& error) {
            failures += "\n  " + candidate.platform + ": " + error.cause();
            continue; // the destructor releases this candidate
        }
        return result;
    }
    throw Error("EGL", std::nullopt,
                "no headless OpenGL " + std::to_string(options.versionMajor) + "." + std::to_string(options.versionMinor) +
                    " core context could be created (install Mesa: libegl-mesa0 libgl1-mesa-dri):" + failures);
}

} // namespace lightskin::gl
