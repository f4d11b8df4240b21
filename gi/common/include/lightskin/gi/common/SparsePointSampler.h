#pragma once
// Sparse scene points of one mesh (LightSkin section 3.2), computed at mesh load in model space,
// with no lighting: N points on the surface, each vertex's kVertexNeighbours nearest points, each
// point's occluder-disc radius (section 3.3), and optional refinement of meshes coarser than the
// point spacing (the paper's stated limitation, section 6).
//
// Sampling: farthest-point sampling (FPS) over a dense, area-uniform random candidate set of the
// surface (Euclidean distance). Chosen over Poisson-disk dart throwing because it gives exactly N
// points (no radius to tune), is deterministic for a seed, and is progressive: the first k points of
// an N-point set are the k-point set, so changing N at run time keeps the existing points (no
// popping in the interpolation). Cost O(M log M) with M candidates, using a PCL kd-tree radius
// search to update only the candidates near each new point.
//
// Spacing: the nominal spacing of N points on a surface of area A is sqrt(A / N) (metres).

#include <lightskin/core/TriangleMesh.h>
#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gi/common/SparsePointSet.h>

#include <cstdint>
#include <functional>
#include <span>

namespace lightskin::gi {

struct SparsePointSettings {
    /// N, the number of sparse points per mesh, in [1, 65536] (the paper uses 64..16k; 256 per model in Fig. 5).
    int pointCount = 1024;
    /// Candidates per sparse point (M = candidatesPerPoint * N, at least 4096): more gives a more
    /// even FPS result, fewer a faster preparation.
    int candidatesPerPoint = 8;
    std::uint32_t seed = 1;
    /// Refine the mesh (see refineMeshToEdgeLength) until its longest edge is <= the spacing.
    bool refine = true;
    /// Refinement cap: stop splitting once the mesh has this many triangles; tessellationRatio then
    /// reports the remaining mismatch.
    std::size_t maxRefinedTriangles = 2'000'000;
};

/// Checks the settings; throws lightskin::Error naming the bad field.
void validate(const SparsePointSettings& settings);

/// Total triangle area, m^2.
double surfaceArea(const TriangleMesh& mesh);
/// Longest edge, metres.
double longestEdge(const TriangleMesh& mesh);
/// Nominal spacing sqrt(A / N) of N points on the mesh, metres.
double nominalSpacing(const TriangleMesh& mesh, int pointCount);

/// Conforming refinement by edge midpoints: each pass splits every edge longer than maxEdge at its
/// midpoint (shared by both triangles, so no cracks) and splits each triangle by its number of split
/// edges (1 -> 2, 2 -> 3, 3 -> 4 triangles, orientation kept). New vertices average their edge's
/// normals (renormalised) and texture coordinates. Stops when no edge is longer than maxEdge or the
/// next pass would exceed maxTriangles. Returns the number of passes made.
int refineMeshToEdgeLength(TriangleMesh& mesh, double maxEdge, std::size_t maxTriangles);

/// Samples the sparse points of `mesh` (not modified). tessellationRatio = longestEdge / spacing.
/// Throws lightskin::Error (naming `meshName`) for an invalid mesh or one without surface area.
SparsePointSet sampleSparsePoints(const TriangleMesh& mesh, const SparsePointSettings& settings,
                                  const std::string& meshName = "mesh");

/// Deformation: each point's position and normal from its anchor on `mesh` (a deformed copy of the sampled mesh:
/// same indices, vertices moved, model space), as sampleSparsePoints placed it on the rest mesh: the barycentric
/// mix of the corners and of their normals (renormalised; the face normal where they cancel). Radii and vertex
/// neighbours are left alone (refitOccluderRadiiInto). No allocation.
/// `anchors` and `points` have the same size; every anchor's triangle must exist in `mesh`.
void followSurfaceInto(const TriangleMesh& mesh, std::span<const SurfaceAnchor> anchors, std::span<SparsePoint> points);

/// Deformation, after followSurfaceInto: each point's occluder radius is again the distance to the farthest vertex
/// it owns (the vertices whose first neighbour it is), as sampleSparsePoints set it, so the discs still reach a
/// stretched surface (a 90 degree bend of the sample cylinder stretches it 1.8x: docs/PLUGIN.md "Moving content").
/// Points that own no vertex keep their radius. The neighbours are kept: a deformation changes the nearest point of
/// a few vertices (3 % at that bend), whose interpolation then reads a point one place further. O(vertices), no
/// allocation. `vertexNeighbours` has one entry per vertex of `mesh`, indexing `points`.
void refitOccluderRadiiInto(const TriangleMesh& mesh,
                            std::span<const std::array<std::uint32_t, kVertexNeighbours>> vertexNeighbours,
                            std::span<SparsePoint> points);

/// Load-time entry point: refines `mesh` in place when settings.refine and it is coarser than the
/// spacing (logs what it did, or a warning when the cap stops it), then samples. The renderer must
/// draw the refined mesh, since vertexNeighbours index its vertices.
SparsePointSet prepareSparsePoints(TriangleMesh& mesh, const SparsePointSettings& settings,
                                   const std::string& meshName = "mesh");

/// Computes the sparse points of one placed mesh (model space) when a technique prepares its
/// meshes. Tests may build sets directly; applications use samplingProvider().
using SparsePointProvider = std::function<SparsePointSet(const MeshInstance& instance)>;

/// The project's provider: sampleSparsePoints(*instance.mesh, settings) (no refinement: a mesh
/// that needs it must be refined with prepareSparsePoints() or refineMeshToEdgeLength() at load,
/// before it is uploaded, since vertexNeighbours index the drawn vertices).
SparsePointProvider samplingProvider(const SparsePointSettings& settings);

} // namespace lightskin::gi
