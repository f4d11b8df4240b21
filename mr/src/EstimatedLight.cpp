#include <lightskin/mr/EstimatedLight.h>

#include <glm/geometric.hpp>

#include <cmath>
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

} // namespace lightskin::mr
