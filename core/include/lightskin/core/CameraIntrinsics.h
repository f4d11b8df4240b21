#pragma once
// Pinhole intrinsics with OpenCV's distortion model, for one image stream.
// Pixel convention: (0,0) is the centre of the top-left pixel (OpenCV). Units: pixels.

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <string>

namespace lightskin {

struct CameraIntrinsics {
    int width = 0;  ///< image width, pixels
    int height = 0; ///< image height, pixels
    double fx = 0.0, fy = 0.0; ///< focal lengths, pixels. fy may be negative (ICL-NUIM's convention).
    double cx = 0.0, cy = 0.0; ///< principal point, pixels
    /// OpenCV order k1, k2, p1, p2, k3. All zero = no distortion (rectified or synthetic images).
    std::array<double, 5> distortion{};

    bool isValid() const noexcept;
    bool hasDistortion() const noexcept;

    /// Back-projects pixel (u,v) at depth z (metres along the optical axis) to camera coordinates,
    /// ignoring distortion (callers undistort first when hasDistortion()).
    glm::dvec3 backProject(double u, double v, double z) const noexcept {
        return {(u - cx) * z / fx, (v - cy) * z / fy, z};
    }
    /// Projects a camera-frame point (z > 0) to pixel coordinates, ignoring distortion.
    glm::dvec2 project(const glm::dvec3& point) const noexcept {
        return {fx * point.x / point.z + cx, fy * point.y / point.z + cy};
    }
    /// The same camera at another resolution (a VAL map at 1/s of the depth map, for example).
    /// Pixel centres are kept consistent: cx' = (cx + 0.5) * sx - 0.5.
    CameraIntrinsics scaledTo(int newWidth, int newHeight) const noexcept;

    std::string describe() const;

    /// Well-known defaults (see docs and ../shared/FACTS.md).
    static CameraIntrinsics kinectV1Default();   ///< 640x480, 525/525/319.5/239.5 (ROS default)
    static CameraIntrinsics tumFreiburg1();      ///< 640x480, 517.3/516.5/318.6/255.3 (+ distortion)
    static CameraIntrinsics tumFreiburg2();      ///< 640x480, 520.9/521.0/325.1/249.7 (+ distortion)
    static CameraIntrinsics tumFreiburg3();      ///< 640x480, 535.4/539.2/320.1/247.6
};

} // namespace lightskin
