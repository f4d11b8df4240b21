#pragma once
// The virtual meshes in world space for multi-scale PRT's ray queries (Embree 3): closest hits of the
// random walks and obscurance rays, segment occlusion of the connections and of the scene lights.
// Private to gi (Embree stays out of public headers).
#include <lightskin/gi/IndirectIllumination.h>

#include <glm/vec3.hpp>

#include <memory>
#include <span>
#include <vector>

namespace lightskin::gi::detail {

struct PrtHit {
    bool hit = false;
    float distance = 0.0f;  ///< metres along the unit direction
    glm::vec3 normal{0.0f}; ///< unit face normal (counter-clockwise front), world
    glm::vec3 albedo{0.0f}; ///< the hit instance's diffuse albedo
    bool frontFace = false; ///< the ray arrived on the side the normal points to
};

class PrtRayScene {
public:
    PrtRayScene();
    ~PrtRayScene();
    PrtRayScene(PrtRayScene&&) noexcept;
    PrtRayScene& operator=(PrtRayScene&&) noexcept;

    /// World triangles of every instance (model * world_T_model). Throws lightskin::Error on Embree failure.
    static PrtRayScene create(std::span<const MeshInstance> instances);

    /// Closest hit along a unit direction within (tnear, tfar]. Thread-safe.
    PrtHit intersect(const glm::vec3& origin, const glm::vec3& direction, float tnear, float tfar) const;
    /// True when a triangle lies on the open segment from..to (shortened by `epsilon` metres at both ends).
    bool occluded(const glm::vec3& from, const glm::vec3& to, float epsilon) const;

    /// World triangles with their area, face normal and instance (for area sampling).
    struct Triangle {
        glm::vec3 a, b, c, normal;
        float area;
        std::uint32_t instance;
    };
    const std::vector<Triangle>& triangles() const;
    float diagonal() const;          ///< of the world bounding box, metres
    glm::vec3 averageAlbedo() const; ///< area-weighted diffuse albedo of all triangles

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::gi::detail
