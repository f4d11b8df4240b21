#include <lightskin/core/Error.h>
#include <lightskin/mr/SceneContent.h>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <cmath>

namespace lightskin::mr {

namespace {

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

[[noreturn]] void fail(const std::string& source, const std::string& what, const std::string& cause) {
    throw Error(source, std::nullopt, what + ": " + cause);
}

} // namespace

void checkPlacement(const glm::mat4& m, const std::string& source, const std::string& what) {
    for (int c = 0; c < 4; ++c)
        if (!finite(glm::vec3(m[c])) || !std::isfinite(m[c][3]))
            fail(source, what, "the transform has a non-finite element");
    if (m[0][3] != 0.0f || m[1][3] != 0.0f || m[2][3] != 0.0f || m[3][3] != 1.0f)
        fail(source, what, "the transform's last row must be 0 0 0 1 (an affine placement)");
    const glm::mat3 a(m);
    const float sx = glm::length(a[0]), sy = glm::length(a[1]), sz = glm::length(a[2]);
    if (!(sx > 1e-6f && sy > 1e-6f && sz > 1e-6f) || !std::isfinite(glm::determinant(a)) ||
        std::abs(glm::determinant(a)) < 1e-18f)
        fail(source, what, "the transform is singular (a zero scale)");
    // Rounding of a composed float rotation stays near 1e-6; 1e-3 is a visible stretch or shear.
    constexpr float kTolerance = 1e-3f;
    const float s = (sx + sy + sz) / 3.0f;
    const bool uniform =
        std::abs(sx - s) <= kTolerance * s && std::abs(sy - s) <= kTolerance * s && std::abs(sz - s) <= kTolerance * s;
    const bool orthogonal = std::abs(glm::dot(a[0], a[1])) <= kTolerance * s * s &&
                            std::abs(glm::dot(a[0], a[2])) <= kTolerance * s * s &&
                            std::abs(glm::dot(a[1], a[2])) <= kTolerance * s * s;
    if (!uniform || !orthogonal)
        fail(source, what, "the transform must be a rotation times one uniform scale (no shear, no stretch)");
}

void checkMaterial(const render::MaterialOverride& material, const std::string& source, const std::string& what) {
    const auto albedo = [&](const std::optional<glm::vec3>& v, const char* name) {
        if (v && !(finite(*v) && glm::all(glm::greaterThanEqual(*v, glm::vec3(0.0f))) &&
                   glm::all(glm::lessThanEqual(*v, glm::vec3(1.0f)))))
            fail(source, what, std::string(name) + " must be in [0, 1] (linear RGB)");
    };
    albedo(material.diffuseAlbedo, "diffuse albedo");
    albedo(material.specularAlbedo, "specular albedo");
    if (material.specularExponent && !(std::isfinite(*material.specularExponent) && *material.specularExponent >= 1.0f))
        fail(source, what, "the specular exponent must be >= 1");
}

void checkLightValues(const render::SceneLight& light, const std::string& source, const std::string& what) {
    if (!finite(light.position)) fail(source, what, "the position must be finite (metres)");
    if (!finite(light.power) || glm::any(glm::lessThan(light.power, glm::vec3(0.0f))))
        fail(source, what, "the power must be finite and >= 0 (watts)");
    if (light.type == render::LightType::Spot && !(finite(light.direction) && glm::length(light.direction) > 1e-6f))
        fail(source, what, "a spot light needs a finite, non-zero direction");
}

double AnimationClock::timeOf(const RgbdFrame& frame) {
    const double t = frame.colourTimestampSeconds;
    if (firstIndex_ < 0) {
        firstIndex_ = frame.index;
        firstTimestamp_ = t;
    }
    if (std::isfinite(t) && std::isfinite(firstTimestamp_)) return std::max(0.0, t - firstTimestamp_);
    return double(std::max<std::int64_t>(0, frame.index - firstIndex_)) / 30.0;
}

void sampleAnimations(render::Scene& scene, double timeSeconds) {
    for (render::SceneObject& object : scene.objects)
        if (render::isAnimated(object)) object.world_T_model = render::placementAt(object, timeSeconds);
    for (render::SceneLight& light : scene.lights) {
        if (!light.animation) continue;
        const render::LightKey key = render::sampleLight(*light.animation, timeSeconds);
        light.position = key.position;
        light.direction = key.direction;
        light.power = key.power;
    }
}

} // namespace lightskin::mr
