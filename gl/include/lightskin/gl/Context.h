#pragma once
// OpenGL 4.5 core contexts: headless through EGL (Mesa surfaceless or device platform, pbuffer
// fallback) and a GLFW window. A context is current on the thread that created it.
// Ownership: GL objects must be destroyed while their context is alive and current.
//
// Engines that own their GL context do not need these classes: every other lightskin GL class
// only requires *some* current 4.5 core context.

#include <functional>
#include <memory>
#include <string>

namespace lightskin::gl {

struct ContextOptions {
    int versionMajor = 4;
    int versionMinor = 5;
    /// Request a debug context and install the KHR_debug callback (DebugOutput).
    bool debug = true;
};

class Context {
public:
    virtual ~Context() = default;
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;

    virtual void makeCurrent() = 0;
    /// "egl-surfaceless", "egl-device", "egl-pbuffer" or "glfw-window".
    virtual std::string platformName() const = 0;

    /// GL_RENDERER / GL_VENDOR / GL_VERSION of the current context.
    std::string renderer() const;
    std::string vendor() const;
    std::string version() const;
    /// One line for logs and reports: "llvmpipe (LLVM 15.0.6, 256 bits) | 4.5 (Core Profile) Mesa 22.3.6 | egl-surfaceless".
    std::string describe() const;

protected:
    Context() = default;
    /// Checks the version, installs debug output, logs the renderer. Called by the factories.
    void finishInitialisation(const ContextOptions& options);
};

/// Throws lightskin::Error when no EGL platform gives a 4.5 core context.
std::unique_ptr<Context> createHeadlessContext(const ContextOptions& options = {});

class WindowContext : public Context {
public:
    virtual void swapBuffers() = 0;
    virtual void pollEvents() = 0;
    virtual bool shouldClose() const = 0;
    virtual void requestClose() = 0;
    /// Framebuffer size in pixels (may differ from the window size on high-DPI screens).
    virtual void framebufferSize(int& width, int& height) const = 0;
    /// Called with GLFW key codes on key press.
    virtual void setKeyHandler(std::function<void(int key)> handler) = 0;
    virtual void setTitle(const std::string& title) = 0;
};

/// Throws lightskin::Error when there is no display or no 4.5 core context.
std::unique_ptr<WindowContext> createWindowContext(int width, int height, const std::string& title,
                                                   const ContextOptions& options = {});

} // namespace lightskin::gl
