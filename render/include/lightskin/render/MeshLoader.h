#pragma once
// Loading virtual content from mesh files (OBJ + MTL, PLY, glTF 2.0, and whatever else the installed
// assimp reads) into lightskin's TriangleMesh + Material: model space = the file's root frame in
// the file's units, read as metres. Every repair is counted in MeshLoadReport and logged, never
// silent; bad files throw lightskin::Error naming the file. The repairs, the errors and the material
// mapping: docs/SCENE_FORMAT.md, "Mesh files".

#include <lightskin/core/Material.h>
#include <lightskin/core/TriangleMesh.h>

#include <glm/vec3.hpp>

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace lightskin::render {

/// Crease angle for generated normals, degrees.
inline constexpr float kCreaseAngleDegrees = 60.0f;

struct MeshPart {
    std::string name;  ///< the mesh's name in the file (may be empty)
    TriangleMesh mesh; ///< validated: finite, indices in range, normals unit length
    Material material;
    std::string materialName;
    glm::vec3 emission{0.0f}; ///< linear RGB emitted radiance as stored in the file (see above)
};

struct MeshLoadReport {
    std::size_t droppedDegenerateTriangles = 0;
    /// triangles over the same three corner positions as another (all copies but the one wound like its
    /// neighbours; before normals are generated, which the reversed copies would turn)
    std::size_t droppedDuplicateTriangles = 0;
    std::size_t removedUnusedVertices = 0;
    std::size_t partsWithGeneratedNormals = 0;
    std::size_t repairedNormals = 0; ///< generated normals that were zero/non-finite, set to +z
    /// Open boundaries (findOpenBoundaries), summed over the parts: edges of only one triangle, and their
    /// loops (the mesh's holes; a scan's holes, or a surface that is open by design). Not repaired: through a
    /// hole the camera sees the object's inside (back faces), which the GI leaves dark
    /// (gi::GBufferView::worldNormal); Renderer::setScene warns once per model.
    std::size_t boundaryEdges = 0;
    std::size_t boundaryLoops = 0;
};

/// Open boundaries of a triangle mesh, with corners joined by their exact position (a vertex split at a
/// crease or a UV seam is one corner): an edge used by exactly one triangle is a boundary edge (edges of
/// three or more triangles are non-manifold, not open); loops = connected components of the boundary
/// edges (a hole's rim; two rims sharing a corner count as one). A closed mesh has 0 and 0.
struct OpenBoundaries {
    std::size_t edges = 0;
    std::size_t loops = 0;
};
OpenBoundaries findOpenBoundaries(const TriangleMesh& mesh);

/// The warning for a model with open boundaries (what it means for the GI), or "" for a closed one.
std::string openBoundaryWarning(const std::string& meshFile, const MeshLoadReport& report);

struct LoadedModel {
    std::filesystem::path path;
    std::vector<MeshPart> parts; ///< at least one, each with at least one triangle
    MeshLoadReport report;

    std::size_t triangleCount() const noexcept;
    std::size_t vertexCount() const noexcept;
};

/// Loads `path`. Throws lightskin::Error naming the file (and the part) on the errors listed above.
LoadedModel loadModel(const std::filesystem::path& path);

/// Drops degenerate triangles (a repeated index or zero area) and vertices no triangle uses, in
/// place; returns {dropped triangles, removed vertices}. Indices must be in range (validate first).
struct DegenerateRepair {
    std::size_t droppedTriangles = 0;
    std::size_t removedVertices = 0;
};
DegenerateRepair removeDegenerateTriangles(TriangleMesh& mesh);

} // namespace lightskin::render
