#pragma once
// Analytic depth maps with exact normals for the VAL tests: planes and spheres ray-cast through
// a pinhole camera (camera frame: x right, y down, z forward; metres).
#include <lightskin/core/CameraIntrinsics.h>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <opencv2/core/mat.hpp>

#include <cmath>
#include <limits>
#include <optional>

namespace lightskin::test {

/// Ray through pixel (u, v) with z component 1.
inline glm::dvec3 pixelRay(const CameraIntrinsics& K, double u, double v) {
    return {(u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0};
}

struct PlaneSurface {
    glm::dvec3 normal; ///< unit, facing the camera
    double offset;     ///< n . X = offset
    std::optional<double> hit(const glm::dvec3& ray) const {
        const double d = glm::dot(normal, ray);
        if (std::abs(d) < 1e-15) return std::nullopt;
        const double t = offset / d;
        return t > 0 ? std::optional<double>(t) : std::nullopt;
    }
    glm::dvec3 normalAt(const glm::dvec3&) const { return normal; }
};

struct SphereSurface {
    glm::dvec3 centre;
    double radius;
    std::optional<double> hit(const glm::dvec3& ray) const {
        const double a = glm::dot(ray, ray), b = -2.0 * glm::dot(ray, centre),
                     c = glm::dot(centre, centre) - radius * radius;
        const double disc = b * b - 4 * a * c;
        if (disc < 0) return std::nullopt;
        const double t = (-b - std::sqrt(disc)) / (2 * a);
        return t > 0 ? std::optional<double>(t) : std::nullopt;
    }
    glm::dvec3 normalAt(const glm::dvec3& point) const { return glm::normalize(point - centre); }
};

/// Depth (CV_32FC1 metres; NaN where nothing is hit) and exact normals (CV_64FC3) of the nearest surface.
template <typename... Surfaces>
void renderDepth(const CameraIntrinsics& K, cv::Mat& depth, cv::Mat& normals, const Surfaces&... surfaces) {
    depth.create(K.height, K.width, CV_32FC1);
    normals.create(K.height, K.width, CV_64FC3);
    for (int v = 0; v < K.height; ++v)
        for (int u = 0; u < K.width; ++u) {
            const glm::dvec3 ray = pixelRay(K, u, v);
            double best = std::numeric_limits<double>::infinity();
            glm::dvec3 n(0.0);
            const auto consider = [&](const auto& surface) {
                if (const auto t = surface.hit(ray); t && *t < best) {
                    best = *t;
                    n = surface.normalAt(ray * *t);
                }
            };
            (consider(surfaces), ...);
            depth.at<float>(v, u) = std::isfinite(best) ? float(best) : std::numeric_limits<float>::quiet_NaN();
            normals.at<cv::Vec3d>(v, u) = cv::Vec3d(n.x, n.y, n.z);
        }
}

} // namespace lightskin::test
