#include "SyntheticRoom.h"

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <algorithm>
#include <limits>

namespace lightskin::test {

namespace {

/// Slab test: the entry and exit ray parameters of a box (entry > exit when missed).
std::pair<double, double> slabs(const glm::dvec3& origin, const glm::dvec3& direction, const glm::dvec3& lo,
                                const glm::dvec3& hi) {
    double enter = -std::numeric_limits<double>::infinity(), exit = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
        const double t0 = (lo[a] - origin[a]) / direction[a], t1 = (hi[a] - origin[a]) / direction[a];
        enter = std::max(enter, std::min(t0, t1));
        exit = std::min(exit, std::max(t0, t1));
    }
    return {enter, exit};
}

} // namespace

CameraIntrinsics syntheticRoomIntrinsics() {
    CameraIntrinsics k;
    k.width = 320;
    k.height = 240;
    k.fx = k.fy = 262.5;
    k.cx = 159.5;
    k.cy = 119.5;
    return k;
}

cv::Mat renderRoomDepth(const SyntheticRoom& room, const CameraIntrinsics& k, const Pose& world_T_camera) {
    cv::Mat depth(k.height, k.width, CV_32FC1, cv::Scalar(0));
    const glm::dvec3 origin = world_T_camera.translation();
    for (int v = 0; v < k.height; ++v) {
        for (int u = 0; u < k.width; ++u) {
            // The camera ray with z = 1: its parameter t is the depth along z.
            const glm::dvec3 ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
            const glm::dvec3 direction = world_T_camera.transformDirection(ray);
            double t = slabs(origin, direction, room.roomMin, room.roomMax).second; // from inside: the exit
            const auto [enter, exit] = slabs(origin, direction, room.tableMin, room.tableMax);
            if (enter <= exit && enter > 0.0) t = std::min(t, enter);
            depth.at<float>(v, u) = float(t);
        }
    }
    return depth;
}

Pose lookAt(const glm::dvec3& position, const glm::dvec3& target) {
    const glm::dvec3 forward = glm::normalize(target - position);
    const glm::dvec3 right = glm::normalize(glm::cross(forward, glm::dvec3(0.0, 0.0, 1.0)));
    const glm::dvec3 down = glm::cross(forward, right);
    glm::dmat4 m(1.0);
    m[0] = glm::dvec4(right, 0.0);
    m[1] = glm::dvec4(down, 0.0);
    m[2] = glm::dvec4(forward, 0.0);
    m[3] = glm::dvec4(position, 1.0);
    return Pose::fromMatrix(m);
}

} // namespace lightskin::test

#include <random>

namespace lightskin::test {

void addKinectNoise(cv::Mat& depth, unsigned seed) {
    std::mt19937 random(seed);
    std::normal_distribution<double> normal(0.0, 1.0);
    for (int v = 0; v < depth.rows; ++v)
        for (int u = 0; u < depth.cols; ++u) {
            float& z = depth.at<float>(v, u);
            if (z <= 0.0f) continue;
            const double sigma = 0.0012 + 0.0019 * (double(z) - 0.4) * (double(z) - 0.4);
            z = float(double(z) + sigma * normal(random));
        }
}

} // namespace lightskin::test
