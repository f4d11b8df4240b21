#include <lightskin/core/Error.h>
#include <lightskin/core/LeakCheck.h>
#include <lightskin/gl/Context.h>

#include <epoxy/gl.h>
// GLFW after epoxy, and without its own GL header.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>


namespace lightskin::gl {

namespace {

// GLFW is process-global: initialised on first window, counted, terminated with the last.
int& glfwUsers() {
    static int users = 0;
    return users;
}
std::string& lastGlfwError() {
    static std::string text;
    return text;
}

class GlfwWindowContext final : public WindowContext {
public:
    explicit GlfwWindowContext(GLFWwindow* window) : window_(window) {
        glfwSetWindowUserPointer(window_, this);
        glfwSetKeyCallback(window_, [](GLFWwindow* w, int key, int, int action, int) {
            auto* self = static_cast<GlfwWindowContext*>(glfwGetWindowUserPointer(w));
            if (action == GLFW_PRESS && self->keyHandler_) self->keyHandler_(key);
        });
    }
    ~GlfwWindowContext() override {
        glfwDestroyWindow(window_);
        if (--glfwUsers() == 0) glfwTerminate();
    }
    void makeCurrent() override { glfwMakeContextCurrent(window_); }
    std::string platformName() const override { return "glfw-window"; }
    void swapBuffers() override { glfwSwapBuffers(window_); }
    void pollEvents() override { glfwPollEvents(); }
    bool shouldClose() const override { return glfwWindowShouldClose(window_) != 0; }
    void requestClose() override { glfwSetWindowShouldClose(window_, GLFW_TRUE); }
    void framebufferSize(int& width, int& height) const override { glfwGetFramebufferSize(window_, &width, &height); }
    void setKeyHandler(std::function<void(int)> handler) override { keyHandler_ = std::move(handler); }
    void setTitle(const std::string& title) override { glfwSetWindowTitle(window_, title.c_str()); }
    void initialise(const ContextOptions& options) { finishInitialisation(options); }

private:
    GLFWwindow* window_;
    std::function<void(int)> keyHandler_;
};

} // namespace

std::unique_ptr<WindowContext> createWindowContext(int width, int height, const std::string& title,
                                                   const ContextOptions& options) {
    glfwSetErrorCallback([](int code, const char* description) {
        lastGlfwError() = "GLFW error " + std::to_string(code) + ": " + (description ? description : "");
    });
    if (glfwUsers() == 0 && !glfwInit())
        throw Error("GLFW", std::nullopt, "glfwInit failed (no display? set DISPLAY or use headless mode): " + lastGlfwError());
    ++glfwUsers();
    glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_API);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, options.versionMajor);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, options.versionMinor);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_OPENGL_DEBUG_CONTEXT, options.debug ? GLFW_TRUE : GLFW_FALSE);
    GLFWwindow* window = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
    if (!window) {
        if (--glfwUsers() == 0) glfwTerminate();
        throw Error("GLFW", std::nullopt, "could not open a window with an OpenGL " + std::to_string(options.versionMajor) +
                                              "." + std::to_string(options.versionMinor) + " core context: " + lastGlfwError());
    }
    sanitizer::keepLoadedModulesMapped(); // the GLX/DRI driver, for LeakSanitizer's report at exit
    auto context = std::make_unique<GlfwWindowContext>(window);
    context->makeCurrent();
    glfwSwapInterval(0);
    context->initialise(options);
    return context;
}

} // namespace lightskin::gl
