#pragma once
// Loading virtual content from mesh files (OBJ + MTL, PLY, glTF 2.0, and whatever else the
// installed assimp reads) into lightskin's TriangleMesh + Material.
//
// One file gives one or more parts: assimp splits a model by material, and node transforms are
// baked into the vertices (model space = the file's root frame, in the file's units; lightskin
// treats them as metres, so scale in the scene file when the file uses other units).
//
// Repairs, all counted in MeshLoadReport and logged (never silent):
// - polygons are triangulated; points and lines are removed;
// - parts without normals get smooth vertex normals with a crease angle (kCreaseAngleDegrees):
//   edges sharper than that keep separate normals, so boxes stay flat-shaded and scans smooth;
// - degenerate triangles (a repeated vertex or zero area) are dropped; vertices no triangle uses
//   any more are removed;
// - generated normals that come out zero or non-finite (vertices of dropped triangles only) get +z.
// Errors (lightskin::Error naming the file): missing or unreadable file, a format assimp does not
// know, a file with no triangles, an index out of range, a non-finite position, a non-finite normal
// or zero-length normal stored in the file, texture coordinates that are not finite, a PLY whose
// header is cut off or whose binary body is shorter than its header requires (assimp 5.2.5 would
// loop forever or read past the end).
//
// Materials map to the paper's Phong model: Kd -> diffuseAlbedo, Ks -> specularAlbedo,
// Ns (shininess) -> specularExponent (clamped to >= 1), map_Kd -> diffuseTexture (absolute path).
// glTF 2.0 metallic-roughness: baseColorFactor -> diffuseAlbedo, no specular (f_s = 0).
// Emission: Ke when present; OBJ files that store emission as an ambient colour above 1
// (tinyobjloader's cornell_box.mtl: "Ka 20 20 20") report it as emission too. Emission is
// informational: virtual light comes from the scene file's lights.

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
    std::string name;     ///< the mesh's name in the file (may be empty)
    TriangleMesh mesh;    ///< validated: finite, indices in range, normals unit length
    Material material;
    std::string materialName;
    glm::vec3 emission{0.0f}; ///< linear RGB emitted radiance as stored in the file (see above)
};

struct MeshLoadReport {
    std::size_t droppedDegenerateTriangles = 0;
    std::size_t removedUnusedVertices = 0;
    std::size_t partsWithGeneratedNormals = 0;
    std::size_t repairedNormals = 0; ///< generated normals that were zero/non-finite, set to +z
};

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
