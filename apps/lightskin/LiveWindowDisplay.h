#pragma once
// Shows composited frames in a GLFW window (live, replay --window) and reads the window back.

#include <lightskin/gl/Context.h>
#include <lightskin/gl/Objects.h>

#include <opencv2/core/mat.hpp>

namespace lightskin::apps {

/// Shows BGR images in the window: uploads into a texture, blits to the default framebuffer
/// (flipped: image row 0 is the top, GL row 0 the bottom), scaled to the framebuffer size.
/// Owns GL objects: destroy before the window's context.
class WindowDisplay {
public:
    void show(gl::WindowContext& window, const cv::Mat& bgr);
    /// The window's back buffer as BGR, top row first (what show() drew, before swapBuffers()).
    static cv::Mat readBack(gl::WindowContext& window);

private:
    gl::Texture texture_;
    gl::Framebuffer framebuffer_;
};

} // namespace lightskin::apps
