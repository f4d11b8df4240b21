#pragma once
// The model's light terms (RoomLightEstimator.h), shared by the fit and the prediction. Internal to roomlight.

#include "LightModelFit.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace lightskin::roomlight {

/// G(x) of the free light (RoomLightEstimator.h). |v|^2 is floored so that a sample next to the light
/// does not dominate the fit.
inline double freeLightTerm(const FreeLight& light, const glm::dvec3& reference, const glm::dvec3& position,
                            const glm::dvec3& normal) noexcept {
    const glm::dvec3 v = light.direction - light.inverseDistance * (position - reference);
    const double cosine = glm::dot(normal, v);
    if (cosine <= 0.0) return 0.0;
    const double squared = std::max(glm::dot(v, v), 0.05);
    return cosine / (squared * std::sqrt(squared));
}

inline double emitterTerm(const AreaEmitter& emitter, const glm::dvec3& position, const glm::dvec3& normal) noexcept {
    const glm::dvec3 toSample = position - emitter.positionWorld;
    const double squared = glm::dot(toSample, toSample);
    if (!(squared > 0.0)) return 0.0;
    const double distance = std::sqrt(squared);
    const double cosEmitter = glm::dot(emitter.normalWorld, toSample) / distance;
    const double cosSample = -glm::dot(normal, toSample) / distance;
    if (cosEmitter <= 0.0 || cosSample <= 0.0) return 0.0;
    return emitter.areaSquareMetres * cosEmitter * cosSample / (squared + emitter.areaSquareMetres / kPi);
}

} // namespace lightskin::roomlight
