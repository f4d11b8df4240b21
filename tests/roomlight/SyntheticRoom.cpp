#include "SyntheticRoom.h"

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>

namespace lightskin::roomlight::test {
namespace {
constexpr double kPiHere = 3.14159265358979323846;

std::optional<double> hitSphere(const Sphere& sphere, const glm::dvec3& origin, const glm::dvec3& direction) {
    const glm::dvec3 oc = origin - sphere.centre;
    const double a = glm::dot(direction, direction), b = glm::dot(oc, direction);
    const double c = glm::dot(oc, oc) - sphere.radius * sphere.radius;
    const double discriminant = b * b - a * c;
    if (discriminant < 0.0) return std::nullopt;
    const double t = (-b - std::sqrt(discriminant)) / a;
    if (t > 1e-9) return t;
    return std::nullopt;
}

std::uint8_t encodeSrgb(double linear) {
    linear = std::clamp(linear, 0.0, 1.0);
    const double encoded = linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
    return static_cast<std::uint8_t>(std::lround(encoded * 255.0));
}
} // namespace

bool SyntheticRoom::visible(const glm::dvec3& from, const glm::dvec3& to) const {
    const glm::dvec3 direction = to - from;
    for (const Sphere& sphere : spheres) {
        const auto t = hitSphere(sphere, from, direction);
        if (t && *t < 1.0 - 1e-9) return false;
    }
    return true;
}

glm::dvec3 SyntheticRoom::irradiance(const glm::dvec3& x, const glm::dvec3& n, int subdivisions) const {
    const glm::dvec3 start = x + 1e-6 * n;
    glm::dvec3 e{kPiHere * skyConstant + 2.0 * kPiHere / 3.0 * skyGradient * n.z};
    for (const PointLight& light : pointLights) {
        const glm::dvec3 toLight = light.position - x;
        const double d2 = glm::dot(toLight, toLight);
        const double cosine = glm::dot(n, toLight) / std::sqrt(d2);
        if (cosine > 0.0 && visible(start, light.position)) e += light.intensity * cosine / d2;
    }
    for (const DirectionalLight& light : directionalLights) {
        const double cosine = glm::dot(n, light.towardLight);
        if (cosine > 0.0 && visible(start, start + 100.0 * light.towardLight)) e += light.irradiance * cosine;
    }
    for (const RectangleLight& light : rectangleLights) {
        const glm::dvec3 axisV = glm::cross(light.facing, light.axisU);
        const double du = light.width / subdivisions, dv = light.height / subdivisions;
        for (int i = 0; i < subdivisions; ++i) {
            for (int j = 0; j < subdivisions; ++j) {
                const glm::dvec3 p = light.centre + ((i + 0.5) * du - 0.5 * light.width) * light.axisU +
                                     ((j + 0.5) * dv - 0.5 * light.height) * axisV;
                const glm::dvec3 toLight = p - x;
                const double d2 = glm::dot(toLight, toLight);
                const double d = std::sqrt(d2);
                const double cosX = glm::dot(n, toLight) / d, cosE = -glm::dot(light.facing, toLight) / d;
                if (cosX > 0.0 && cosE > 0.0 && visible(start, p)) e += light.radiance * (cosX * cosE * du * dv / d2);
            }
        }
    }
    return e;
}

std::optional<SyntheticRoom::Hit> SyntheticRoom::trace(const glm::dvec3& origin, const glm::dvec3& direction) const {
    double best = std::numeric_limits<double>::max();
    Hit hit;
    for (int axis = 0; axis < 3; ++axis) {
        if (direction[axis] == 0.0) continue;
        const double wall = direction[axis] > 0.0 ? size[axis] : 0.0;
        const double t = (wall - origin[axis]) / direction[axis];
        if (t <= 0.0 || t >= best) continue;
        best = t;
        hit.normal = glm::dvec3(0.0);
        hit.normal[axis] = direction[axis] > 0.0 ? -1.0 : 1.0;
        hit.albedo = axis == 2 ? (direction.z > 0.0 ? ceilingAlbedo : floorAlbedo) : wallAlbedo;
    }
    for (const Sphere& sphere : spheres) {
        const auto t = hitSphere(sphere, origin, direction);
        if (t && *t < best) {
            best = *t;
            hit.normal = glm::normalize(origin + *t * direction - sphere.centre);
            hit.albedo = sphere.albedo;
        }
    }
    if (best == std::numeric_limits<double>::max()) return std::nullopt;
    hit.position = origin + best * direction;
    for (const RectangleLight& light : rectangleLights) {
        const glm::dvec3 offset = hit.position - light.centre;
        const glm::dvec3 axisV = glm::cross(light.facing, light.axisU);
        if (std::abs(glm::dot(offset, light.facing)) < 1e-6 &&
            std::abs(glm::dot(offset, light.axisU)) <= 0.5 * light.width &&
            std::abs(glm::dot(offset, axisV)) <= 0.5 * light.height) {
            hit.onEmitter = true;
            hit.emitted = light.radiance;
        }
    }
    return hit;
}

Pose lookAt(const glm::dvec3& eye, const glm::dvec3& target) {
    const glm::dvec3 forward = glm::normalize(target - eye);
    const glm::dvec3 right = glm::normalize(glm::cross(forward, glm::dvec3(0.0, 0.0, 1.0)));
    const glm::dvec3 down = glm::cross(forward, right);
    return Pose(glm::quat_cast(glm::dmat3(right, down, forward)), eye);
}

CameraIntrinsics testIntrinsics() { return CameraIntrinsics::kinectV1Default(); }

RgbdFrame render(const SyntheticRoom& room, const CameraShot& shot, const CameraIntrinsics& k) {
    RgbdFrame frame;
    frame.colour.create(k.height, k.width, CV_8UC3);
    frame.depth.create(k.height, k.width, CV_16UC1);
    frame.depthScaleMetres = 0.001;
    frame.colourIntrinsics = frame.depthIntrinsics = k;
    frame.colourTimestampSeconds = frame.depthTimestampSeconds = shot.timeSeconds;
    std::mt19937 random(shot.noiseSeed);
    std::normal_distribution<double> gauss(0.0, 1.0);
    const glm::dvec3 eye = shot.world_T_camera.translation();
    for (int v = 0; v < k.height; ++v) {
        for (int u = 0; u < k.width; ++u) {
            const glm::dvec3 rayCamera{(u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0};
            const auto hit = room.trace(eye, shot.world_T_camera.transformDirection(rayCamera));
            glm::dvec3 radiance{0.0};
            double depthMetres = 0.0;
            if (hit) {
                radiance = hit->onEmitter ? hit->emitted
                                          : hit->albedo / kPiHere * room.irradiance(hit->position, hit->normal, 8);
                depthMetres = glm::dot(hit->position - eye, shot.world_T_camera.transformDirection({0.0, 0.0, 1.0}));
            }
            const glm::dvec3 pixel =
                shot.exposure * shot.whiteBalance * radiance * (1.0 + shot.relativeNoise * gauss(random));
            frame.colour.at<cv::Vec3b>(v, u) = {encodeSrgb(pixel.z), encodeSrgb(pixel.y), encodeSrgb(pixel.x)};
            frame.depth.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(std::lround(depthMetres * 1000.0));
        }
    }
    return frame;
}

std::array<glm::dvec3, 9> projectIrradiance(const SyntheticRoom& room, const glm::dvec3& position) {
    constexpr int kTheta = 256, kPhi = 512;
    std::array<glm::dvec3, 9> coefficients{};
    for (int i = 0; i < kTheta; ++i) {
        const double theta = (i + 0.5) * kPiHere / kTheta;
        const double solidAngle = std::sin(theta) * (kPiHere / kTheta) * (2.0 * kPiHere / kPhi);
        for (int j = 0; j < kPhi; ++j) {
            const double phi = (j + 0.5) * 2.0 * kPiHere / kPhi;
            const glm::dvec3 n{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
            const glm::dvec3 e = room.irradiance(position, n, 16);
            // Real orthonormal SH in the (l, m) order of roomlight's header, written out here from their definition.
            const std::array<double, 9> y{0.28209479177387814,
                                          0.4886025119029199 * n.y,
                                          0.4886025119029199 * n.z,
                                          0.4886025119029199 * n.x,
                                          1.0925484305920792 * n.x * n.y,
                                          1.0925484305920792 * n.y * n.z,
                                          0.31539156525252005 * (3.0 * n.z * n.z - 1.0),
                                          1.0925484305920792 * n.x * n.z,
                                          0.5462742152960396 * (n.x * n.x - n.y * n.y)};
            for (std::size_t k = 0; k < 9; ++k) coefficients[k] += e * y[k] * solidAngle;
        }
    }
    return coefficients;
}

} // namespace lightskin::roomlight::test
