#pragma once
// VALs from virtual lights (LightSkin section 4.1, after Dachsbacher & Stamminger's reflective
// shadow maps): the virtual content is rendered from each spot or point light; every covered RSM
// texel becomes one Lambertian disc VAL (world position and normal, flux in W, area in m^2), so
// virtual objects bounce light onto each other (one bounce; specular reflectance is not bounced).
// Per-texel solid angle, flux, area and normal: docs/LIGHTSKIN.md, "VALs from virtual lights".

#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gi/common/VirtualAreaLight.h>
#include <lightskin/gl/Objects.h>

#include <glm/vec3.hpp>

#include <span>
#include <vector>

namespace lightskin::gi {

struct VirtualLight {
    enum class Type { Spot, Point };
    Type type = Type::Spot;
    glm::vec3 position{0.0f};               ///< world, metres
    glm::vec3 direction{0.0f, 0.0f, -1.0f}; ///< spot axis (unit); ignored for point lights
    float spotHalfAngle = 0.5f;             ///< radians, in (0, 1.5]: uniform intensity inside, none outside
    glm::vec3 intensity{1.0f};              ///< radiant intensity I, W/sr, linear RGB
};

/// Radiant power (W, RGB): I * 2 pi (1 - cos beta) for a spot, I * 4 pi for a point light.
glm::dvec3 radiantPower(const VirtualLight& light);

struct RsmSettings {
    int resolution = 64; ///< texels per side per face (VALs per spot light <= resolution^2)
    int maxLights = 4;   ///< buffers hold maxLights * 6 * resolution^2 VALs
    /// Light frustum, metres. Both 0 (default): per light from the bounding sphere of the instances
    /// (far = distance + radius, near = max(distance - radius, 1e-5 far)), so any scene scale works.
    float nearPlane = 0.0f;
    float farPlane = 0.0f;
    bool areaFacingLight = true; ///< the paper's area (see above)
    float minCosine = 0.2f;      ///< clamp for the true-area variant
};

void validate(const RsmSettings& settings);

/// Owns its RSM targets and VAL buffer (GL 4.5 context current from create() to destruction).
class ReflectiveShadowMap {
public:
    ReflectiveShadowMap() = default;
    static ReflectiveShadowMap create(const RsmSettings& settings = {});

    /// Renders every instance (MeshInstance::mesh must be set when the frustum is automatic) into each light's RSM and
    /// appends the VALs of all lights into one packed set (reads the count back). Changes GL state: framebuffer,
    /// viewport, depth test, program. Throws lightskin::Error for more lights than maxLights or an invalid light.
    ValSetView generate(std::span<const VirtualLight> lights, std::span<const MeshInstance> instances);

    ValSetView lastSet() const noexcept { return {vals_.id(), lastCount_}; }
    std::uint32_t capacity() const noexcept { return capacity_; }
    const RsmSettings& settings() const noexcept { return settings_; }
    std::vector<VirtualAreaLight> downloadVals() const;

private:
    RsmSettings settings_;
    std::uint32_t capacity_ = 0, lastCount_ = 0;
    gl::Program rasterProgram_, compactProgram_;
    gl::Texture position_, normal_, albedo_;
    gl::Renderbuffer depth_;
    gl::Framebuffer framebuffer_;
    gl::Buffer vals_, counter_;
};

} // namespace lightskin::gi
