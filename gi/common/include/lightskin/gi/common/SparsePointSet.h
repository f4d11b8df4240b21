#pragma once
// Sparse scene points of one mesh in model space (LightSkin section 3.2): the receivers of the
// gather, the sources of per-vertex interpolation and the occluder discs (section 3.3).
// Computed once at mesh load (no lighting pre-computation); moved with the mesh's transform.

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace lightskin::gi {

struct SparsePoint {
    glm::vec3 position{0.0f};       ///< model space, metres, on the surface
    float occluderRadius = 0.0f;    ///< metres: max distance to a vertex in this point's Voronoi region
    glm::vec3 normal{0.0f, 0.0f, 1.0f}; ///< unit, model space
    float reserved = 0.0f;
};
static_assert(sizeof(SparsePoint) == 32, "SparsePoint must match the GLSL std430 layout");

/// Where a sparse point lies on its mesh: a triangle (index into the mesh's triangles) and the barycentric weights
/// of its second and third corners (the first's is 1 - u - v). The same triangle of a deformed copy of the mesh
/// (same indices, moved vertices) carries the point along: followSurfaceInto (SparsePointSampler.h).
struct SurfaceAnchor {
    std::uint32_t triangle = 0;
    float u = 0.0f, v = 0.0f;
};

/// Number of sparse neighbours each vertex interpolates from (the paper's eight).
inline constexpr int kVertexNeighbours = 8;

struct SparsePointSet {
    std::vector<SparsePoint> points;
    /// Per point, in `points`' order: where it was sampled (sampleSparsePoints fills it; empty for sets built
    /// otherwise, e.g. sparsePointsFromVertices).
    std::vector<SurfaceAnchor> anchors;
    /// Per mesh vertex: indices into `points` of its kVertexNeighbours nearest sparse points,
    /// nearest first. When the set has fewer points than that, the list repeats the last valid
    /// index (interpolation weights treat repeats as the same point).
    std::vector<std::array<std::uint32_t, kVertexNeighbours>> vertexNeighbours;
    /// Largest edge of the mesh divided by the mean sparse-point spacing: > 1 means the mesh is
    /// coarser than the sparse points (the paper's stated limitation; see SparsePointSampler).
    float tessellationRatio = 0.0f;
};

} // namespace lightskin::gi
