#include <lightskin/core/CameraIntrinsics.h>

#include <cmath>
#include <cstdio>

namespace lightskin {

bool CameraIntrinsics::isValid() const noexcept {
    return width > 0 && height > 0 && std::isfinite(fx) && std::isfinite(fy) && std::abs(fx) > 0.0 &&
           std::abs(fy) > 0.0 && std::isfinite(cx) && std::isfinite(cy);
}

bool CameraIntrinsics::hasDistortion() const noexcept {
    for (double k : distortion)
        if (k != 0.0) return true;
    return false;
}

CameraIntrinsics CameraIntrinsics::scaledTo(int newWidth, int newHeight) const noexcept {
    CameraIntrinsics scaled = *this;
    const double sx = double(newWidth) / double(width);
    const double sy = double(newHeight) / double(height);
    scaled.width = newWidth;
    scaled.height = newHeight;
    scaled.fx = fx * sx;
    scaled.fy = fy * sy;
    scaled.cx = (cx + 0.5) * sx - 0.5;
    scaled.cy = (cy + 0.5) * sy - 0.5;
    return scaled;
}

std::string CameraIntrinsics::describe() const {
    char text[256];
    std::snprintf(text, sizeof text, "%dx%d fx=%.3f fy=%.3f cx=%.3f cy=%.3f k=[%g %g %g %g %g]", width, height, fx,
                  fy, cx, cy, distortion[0], distortion[1], distortion[2], distortion[3], distortion[4]);
    return text;
}

// Values: ROS openni_launch default; TUM RGB-D "File Formats / Intrinsic Camera Calibration" page.
CameraIntrinsics CameraIntrinsics::kinectV1Default() { return {640, 480, 525.0, 525.0, 319.5, 239.5, {}}; }
CameraIntrinsics CameraIntrinsics::tumFreiburg1() {
    return {640, 480, 517.3, 516.5, 318.6, 255.3, {0.2624, -0.9531, -0.0054, 0.0026, 1.1633}};
}
CameraIntrinsics CameraIntrinsics::tumFreiburg2() {
    return {640, 480, 520.9, 521.0, 325.1, 249.7, {0.2312, -0.7849, -0.0033, -0.0001, 0.9172}};
}
CameraIntrinsics CameraIntrinsics::tumFreiburg3() { return {640, 480, 535.4, 539.2, 320.1, 247.6, {}}; }

} // namespace lightskin
