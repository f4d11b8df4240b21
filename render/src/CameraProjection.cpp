#include <lightskin/core/Error.h>
#include <lightskin/render/CameraProjection.h>

namespace lightskin::render {

glm::dmat4 clipFromCamera(const CameraIntrinsics& k, double n, double f) {
    LIGHTSKIN_ASSERT(k.isValid(), "lightskin::render::clipFromCamera(): invalid intrinsics");
    LIGHTSKIN_ASSERT(n > 0.0 && f > n, "lightskin::render::clipFromCamera(): need 0 < near < far");
    const double w = double(k.width), h = double(k.height);
    glm::dmat4 m(0.0); // glm: m[column][row]
    m[0][0] = 2.0 * k.fx / w;
    m[2][0] = (2.0 * k.cx + 1.0) / w - 1.0;
    m[1][1] = -2.0 * k.fy / h;
    m[2][1] = 1.0 - (2.0 * k.cy + 1.0) / h;
    m[2][2] = (f + n) / (f - n);
    m[3][2] = -2.0 * f * n / (f - n);
    m[2][3] = 1.0;
    return m;
}

glm::dmat4 clipFromWorld(const CameraIntrinsics& intrinsics, const Pose& world_T_camera, double n, double f) {
    return clipFromCamera(intrinsics, n, f) * world_T_camera.inverse().matrix();
}

glm::dvec2 pixelFromClip(const glm::dvec4& clip, int width, int height) {
    const double xNdc = clip.x / clip.w, yNdc = clip.y / clip.w;
    const double windowX = (xNdc + 1.0) * 0.5 * double(width);
    const double windowY = (yNdc + 1.0) * 0.5 * double(height);
    return {windowX - 0.5, double(height) - windowY - 0.5};
}

} // namespace lightskin::render
