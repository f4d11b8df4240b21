#pragma once
// The virtual meshes in world space as multi-scale PRT samples and traces them: the triangles with area,
// face normal and instance (entry-point sampling), per-instance albedo, and the shared Embree owner
// gi::TriangleRayScene for the random walks, obscurance rays and segment occlusion. Private to gi.
#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gi/common/TriangleRayScene.h>

#include <glm/vec3.hpp>

#include <cstdint>
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

/// A world triangle with its area (m^2), unit face normal and the index of its MeshInstance.
struct PrtTriangle {
    glm::vec3 a, b, c, normal;
    float area;
    std::uint32_t instance;
};

/// Move-only (owns the TriangleRayScene). Queries are const and thread-safe.
struct PrtGeometry {
    TriangleRayScene rays;
    std::vector<PrtTriangle> triangles;
    std::vector<std::uint32_t> firstTriangle; ///< per instance, index into triangles
    std::vector<glm::vec3> albedo;            ///< per instance
    float diagonal = 0.0f;                    ///< of the world bounding box, metres
    glm::vec3 averageAlbedo{0.0f};            ///< area-weighted diffuse albedo of all triangles

    /// Validates every mesh; throws lightskin::Error naming the mesh, or Embree's failure.
    static PrtGeometry create(std::span<const MeshInstance> instances);

    /// Closest hit along a unit direction within [tnear, tfar].
    PrtHit intersect(const glm::vec3& origin, const glm::vec3& direction, float tnear, float tfar) const;
    /// True when a triangle lies on the segment from..to shortened by `epsilon` metres at both ends.
    bool occluded(const glm::vec3& from, const glm::vec3& to, float epsilon) const {
        return rays.segmentOccluded(glm::dvec3(from), glm::dvec3(to), double(epsilon));
    }
};

} // namespace lightskin::gi::detail
