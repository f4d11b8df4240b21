#include <lightskin/mr/EstimatedLight.h>
#include <lightskin/roomlight/SphericalHarmonics.h>

#include <glm/geometric.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>

namespace lightskin::mr {

const char* toString(EstimatedLightUse use) noexcept {
    switch (use) {
    case EstimatedLightUse::None:
        return "none";
    case EstimatedLightUse::Dominant:
        return "dominant";
    case EstimatedLightUse::FreeLight:
        return "free-light";
    case EstimatedLightUse::Rejected:
        return "rejected";
    }
    return "?";
}

namespace {
bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
} // namespace

EstimatedDirectLight estimatedDirectLight(const roomlight::LightEstimate& estimate,
                                          const render::EstimatedLightSettings& settings,
                                          float exposureStops) noexcept {
    using roomlight::DominantSource;
    EstimatedDirectLight out;
    const glm::dvec3 reference = estimate.referencePointWorld;
    out.positionWorld = glm::vec3(reference);
    // The light to draw: its direction, optional position and irradiance at the reference (per channel).
    glm::dvec3 direction, irradiance;
    std::optional<glm::dvec3> position;
    const roomlight::DominantLight& d = estimate.dominant;
    if (d.source == DominantSource::LocalLight || d.source == DominantSource::ShLinearBand) {
        out.use = EstimatedLightUse::Dominant;
        direction = d.directionWorld;
        position = d.positionWorld;
        irradiance = d.colour * d.intensity;
    } else if (d.source == DominantSource::Emitter && glm::dot(estimate.localLightIrradiance, glm::dvec3(1.0)) > 0.0) {
        out.use = EstimatedLightUse::FreeLight;
        direction = estimate.localLightDirectionWorld;
        position = estimate.localLightPositionWorld;
        irradiance = estimate.localLightIrradiance;
    } else {
        return out;
    }
    if (!(finite(direction) && finite(irradiance) && glm::length(direction) > 0.5 && finite(reference)) ||
        (position && !finite(*position))) {
        out.use = EstimatedLightUse::None;
        return out;
    }
    // Band 0 of the irradiance SH is sqrt(4 pi) x its mean over all normals.
    const glm::dvec3 meanIrradiance = estimate.sh[0] / std::sqrt(4.0 * std::numbers::pi);
    constexpr double kMaxLightToMean = 4.0 * 1.05;
    for (int c = 0; c < 3; ++c)
        if (!(meanIrradiance[c] >= 0.0 && irradiance[c] <= kMaxLightToMean * meanIrradiance[c])) {
            out.use = EstimatedLightUse::Rejected;
            return out;
        }
    direction = glm::normalize(direction);
    const double far = settings.distantLightMetres;
    double distance = far;
    glm::dvec3 at = reference + far * direction;
    if (position && glm::length(*position - reference) <= far) {
        at = *position;
        distance = glm::length(*position - reference);
    }
    // I d^2 / d^2 = E0 at the reference; the renderer's irradiance is the camera's / 2^exposureStops.
    const glm::dvec3 intensity =
        glm::max(irradiance, glm::dvec3(0.0)) * distance * distance / std::exp2(double(exposureStops));
    out.positionWorld = glm::vec3(at);
    out.power = glm::vec3(4.0 * std::numbers::pi * intensity);
    out.distanceMetres = float(distance);
    return out;
}

namespace {

std::uint8_t srgbByte(double linear) {
    const double c = std::clamp(linear, 0.0, 1.0);
    const double encoded = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
    return std::uint8_t(std::lround(255.0 * encoded));
}

/// The probe ball: centre and radius in pixels, camera-facing hemisphere, world normals.
void drawProbe(cv::Mat& bgr, const roomlight::ShRgb& sh, const Pose& world_T_camera, cv::Point centre, int radius) {
    for (int dy = -radius; dy <= radius; ++dy)
        for (int dx = -radius; dx <= radius; ++dx) {
            const double x = double(dx) / radius, y = double(dy) / radius, r2 = x * x + y * y;
            const int u = centre.x + dx, v = centre.y + dy;
            if (r2 > 1.0 || u < 0 || v < 0 || u >= bgr.cols || v >= bgr.rows) continue;
            // Camera frame: x right, y down, z forward; the visible side of the ball faces -z.
            const glm::dvec3 normal = world_T_camera.transformDirection({x, y, -std::sqrt(1.0 - r2)});
            const glm::dvec3 value = kProbeAlbedo / std::numbers::pi * roomlight::evaluateSh(sh, normal);
            bgr.at<cv::Vec3b>(v, u) = cv::Vec3b(srgbByte(value.b), srgbByte(value.g), srgbByte(value.r));
        }
}

} // namespace

void drawLightEstimateInto(cv::Mat& bgr, const roomlight::LightEstimate& estimate, const CameraIntrinsics& k,
                           const Pose& world_T_camera) {
    const int radius = std::max(8, std::min(bgr.cols, bgr.rows) / 8);
    const cv::Point centre(radius + 4, bgr.rows - radius - 4);
    drawProbe(bgr, estimate.sh, world_T_camera, centre, radius);
    const Pose camera_T_world = world_T_camera.inverse();
    const cv::Scalar yellow(0, 255, 255), orange(0, 140, 255);
    const auto ringAt = [&](const glm::dvec3& world, const cv::Scalar& colour) {
        const glm::dvec3 c = camera_T_world.transformPoint(world);
        if (c.z <= 0.0) return false;
        const glm::dvec2 p = k.project(c);
        if (p.x < 0.0 || p.y < 0.0 || p.x >= bgr.cols || p.y >= bgr.rows) return false;
        cv::circle(bgr, cv::Point(int(p.x), int(p.y)), std::max(4, radius / 3), colour, 2, cv::LINE_AA);
        return true;
    };
    const roomlight::DominantLight& d = estimate.dominant;
    if (d.source != roomlight::DominantSource::None && !(d.positionWorld && ringAt(*d.positionWorld, yellow))) {
        const glm::dvec3 dc = camera_T_world.transformDirection(d.directionWorld);
        const double length = std::hypot(dc.x, dc.y);
        if (length > 1e-6) {
            const cv::Point tip(centre.x + int(std::lround(1.8 * radius * dc.x / length)),
                                centre.y + int(std::lround(1.8 * radius * dc.y / length)));
            cv::arrowedLine(bgr, centre, tip, yellow, 2, cv::LINE_AA, 0, 0.25);
        }
    }
    for (int e = 0; e < estimate.emitterCount; ++e) ringAt(estimate.emitters[std::size_t(e)].positionWorld, orange);
    char text[96];
    std::snprintf(text, sizeof text, "%s E0 %.3g res %.2f", roomlight::toString(estimate.state), d.intensity,
                  estimate.residual);
    cv::putText(bgr, text, cv::Point(4, 14), cv::FONT_HERSHEY_SIMPLEX, 0.4, yellow, 1, cv::LINE_AA);
}

} // namespace lightskin::mr
