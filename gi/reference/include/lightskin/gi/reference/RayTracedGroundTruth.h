#pragma once
// Ground truth for the LightSkin approximations: one-bounce indirect light at receiver points from the same VAL
// discs, with exact ray-traced visibility against the virtual meshes (Embree 3), in double precision. It uses
// the technique's own reflectance model (lightskin_math.glsl, eq. 5), so LightSkin against it measures what the
// occlusion approximation (section 3.3) and the sparse interpolation cost. World metres; VAL flux W; irradiance
// W/m^2, radiance W/(sr m^2). The integral, the two quadratures and their error, the shadow-ray epsilon:
// docs/LIGHTSKIN.md, "The ray-traced ground truth".

#include <lightskin/core/Material.h>
#include <lightskin/core/TriangleMesh.h>
#include <lightskin/gi/common/VirtualAreaLight.h>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include <memory>
#include <span>

namespace lightskin::gi {

struct GroundTruthSettings {
    int discRings = 8;    ///< >= 1
    int discSectors = 16; ///< >= 1; 1 x 1 = centre mode (see above)
    double rayEpsilon = 1e-4;
    bool visibility = true;               ///< false: no shadow rays (the unoccluded integral)
    int threads = 0;                      ///< receivers are split over this many threads; 0 = hardware concurrency
    double glossyC = 0.15915494309189535; ///< c of eq. 5's c_k = c (k + 1), 1/sr (1 / (2 pi))
};

struct GroundTruthReceiver {
    glm::dvec3 position{0.0};           ///< world, metres
    glm::dvec3 normal{0.0, 0.0, 1.0};   ///< unit, world
    glm::dvec3 toViewer{0.0, 0.0, 1.0}; ///< unit, world: direction of the outgoing radiance
    Material material;
};

struct GroundTruthResult {
    glm::dvec3 irradiance{0.0};           ///< E, W/m^2 (VAL flux units per m^2), with visibility
    glm::dvec3 unoccludedIrradiance{0.0}; ///< the same integral with V = 1
    glm::dvec3 radiance{0.0};             ///< outgoing toward toViewer: diffuse + glossy, with visibility
};

/// The occluding geometry: triangle meshes placed in the world (model space * world_T_model).
struct GroundTruthMesh {
    const TriangleMesh* mesh = nullptr;
    glm::dmat4 world_T_model{1.0};
};

class RayTracedGroundTruth {
public:
    RayTracedGroundTruth();
    ~RayTracedGroundTruth();
    RayTracedGroundTruth(RayTracedGroundTruth&&) noexcept;
    RayTracedGroundTruth& operator=(RayTracedGroundTruth&&) noexcept;

    /// Builds the Embree scene (an empty span gives a scene without occluders). Throws
    /// lightskin::Error when Embree fails or a mesh is invalid.
    static RayTracedGroundTruth create(std::span<const GroundTruthMesh> meshes);

    /// Evaluates every receiver against every VAL (VALs with area <= 0 or non-finite data are skipped).
    /// `out` must have receivers.size() entries. Cost: receivers * VALs * rings * sectors shadow rays.
    void compute(std::span<const VirtualAreaLight> vals, std::span<const GroundTruthReceiver> receivers,
                 std::span<GroundTruthResult> out, const GroundTruthSettings& settings = {}) const;

    /// True when the open segment from `from` to `to` (shortened by rayEpsilon at both ends) hits a triangle.
    bool occluded(const glm::dvec3& from, const glm::dvec3& to, double rayEpsilon = 1e-4) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace lightskin::gi
