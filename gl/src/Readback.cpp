#include <lightskin/gl/Readback.h>

#include <opencv2/core.hpp>

namespace lightskin::gl {

namespace {
void readInto(GLuint texture, int width, int height, int cvType, GLenum format, GLenum type, cv::Mat& out) {
    out.create(height, width, cvType);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glGetTextureImage(texture, 0, format, type, GLsizei(out.total() * out.elemSize()), out.data);
    cv::flip(out, out, 0);
}
void readInto(const Texture& texture, int cvType, GLenum format, GLenum type, cv::Mat& out) {
    readInto(texture.id(), texture.width(), texture.height(), cvType, format, type, out);
}
} // namespace

void readTextureRgba32fInto(const Texture& texture, cv::Mat& out) {
    readInto(texture, CV_32FC4, GL_RGBA, GL_FLOAT, out);
}
void readTextureRgba32fInto(GLuint texture, int width, int height, cv::Mat& out) {
    readInto(texture, width, height, CV_32FC4, GL_RGBA, GL_FLOAT, out);
}
void readTextureRgba8Into(const Texture& texture, cv::Mat& out) {
    readInto(texture, CV_8UC4, GL_RGBA, GL_UNSIGNED_BYTE, out);
}
void readTextureR32fInto(const Texture& texture, cv::Mat& out) { readInto(texture, CV_32FC1, GL_RED, GL_FLOAT, out); }

} // namespace lightskin::gl
