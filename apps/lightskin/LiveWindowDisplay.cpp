#include "LiveWindowDisplay.h"

#include <opencv2/core.hpp>

namespace lightskin::apps {

void WindowDisplay::show(gl::WindowContext& window, const cv::Mat& bgr) {
    if (texture_.width() != bgr.cols || texture_.height() != bgr.rows) {
        texture_ = gl::Texture::create2D(GL_RGB8, bgr.cols, bgr.rows);
        framebuffer_ = gl::Framebuffer::create();
        framebuffer_.attach(GL_COLOR_ATTACHMENT0, texture_);
        framebuffer_.checkComplete("window display");
    }
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, int(bgr.step / bgr.elemSize()));
    glTextureSubImage2D(texture_.id(), 0, 0, 0, bgr.cols, bgr.rows, GL_BGR, GL_UNSIGNED_BYTE, bgr.data);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    int width = 0, height = 0;
    window.framebufferSize(width, height);
    const float black[4] = {0, 0, 0, 1};
    glClearNamedFramebufferfv(0, GL_COLOR, 0, black);
    glBlitNamedFramebuffer(framebuffer_.id(), 0, 0, 0, bgr.cols, bgr.rows, 0, height, width, 0, GL_COLOR_BUFFER_BIT,
                           GL_NEAREST);
}

cv::Mat WindowDisplay::readBack(gl::WindowContext& window) {
    int width = 0, height = 0;
    window.framebufferSize(width, height);
    cv::Mat image(height, width, CV_8UC3);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
    glReadBuffer(GL_BACK);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, width, height, GL_BGR, GL_UNSIGNED_BYTE, image.data);
    cv::flip(image, image, 0);
    return image;
}

} // namespace lightskin::apps
