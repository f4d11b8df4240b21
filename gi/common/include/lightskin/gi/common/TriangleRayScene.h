#pragma once
// Ray queries against world-space triangle meshes: one Embree device, scene and BVH, built once from
// a list of meshes and owned here (the differential's visibility, the ray-traced ground truth and
// synth's objects-present truth and multi-scale PRT's precompute share it; Embree stays out of the public
// headers).
#include <lightskin/core/TriangleMesh.h>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include <cstddef>
#include <memory>
#include <optional>
#include <span>
#include <string>

namespace lightskin::gi {

/// A mesh to trace and where it is. The mesh is only read during create() (not kept).
struct RayMesh {
    const TriangleMesh* mesh = nullptr;
    glm::dmat4 world_T_model{1.0}; ///< model -> world (metres); identity: positions are already world
};

/// The closest hit of TriangleRayScene::intersect.
struct RayHit {
    std::size_t mesh = 0;     ///< index into the meshes given to create()
    std::size_t triangle = 0; ///< triangle index in that mesh
    double u = 0.0, v = 0.0;  ///< barycentrics of vertices 1 and 2 (vertex 0: 1 - u - v)
    double t = 0.0;           ///< ray parameter: hit = origin + t * direction
};

/// Move-only owner of an Embree device + scene (released in the destructor). Queries are const and
/// thread-safe; positions are traced in single precision (Embree's), world frame, metres.
class TriangleRayScene {
public:
    enum class BuildQuality { Medium, High };

    /// Builds the BVH over `meshes` (vertices transformed in double, then stored as float). Meshes
    /// without triangles are skipped. `owner` prefixes error messages ("differential", ...).
    /// Throws lightskin::Error("embree", ...) when Embree fails.
    static TriangleRayScene create(std::span<const RayMesh> meshes, const std::string& owner,
                                   BuildQuality quality = BuildQuality::Medium);

    /// The meshes of create(), in its order, at new placements: their vertices are rewritten and the BVH is
    /// built again on the same device and buffers. Throws like create().
    void place(std::span<const RayMesh> meshes, const std::string& owner);

    TriangleRayScene();
    ~TriangleRayScene();
    TriangleRayScene(TriangleRayScene&&) noexcept;
    TriangleRayScene& operator=(TriangleRayScene&&) noexcept;

    /// Any triangle at origin + t * direction with t in [tNear, tFar]. `direction` need not be unit:
    /// direction = to - from with t in [eps, 1 - eps] tests a segment independent of its scale.
    bool occluded(const glm::dvec3& origin, const glm::dvec3& direction, double tNear, double tFar) const;
    /// Any triangle on the segment from..to shortened by `epsilon` metres at both ends (so the surfaces
    /// the end points lie on do not count); false when the segment is not longer than 2 * epsilon.
    bool segmentOccluded(const glm::dvec3& from, const glm::dvec3& to, double epsilon) const;
    /// The closest hit with t in [tNear, tFar] (tFar may be infinite), or nullopt.
    std::optional<RayHit> intersect(const glm::dvec3& origin, const glm::dvec3& direction, double tNear,
                                    double tFar) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::gi
