#pragma once
// An indexed triangle mesh in model space (metres), as the GI core and the renderer consume it.
// Loading from files (OBJ/PLY/glTF) lives in render/; this type only holds and checks data.

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace lightskin {

struct TriangleMesh {
    std::vector<glm::vec3> positions; ///< model space, metres
    std::vector<glm::vec3> normals;   ///< unit, per vertex; same count as positions
    std::vector<glm::vec2> texcoords; ///< optional: empty or same count as positions
    std::vector<std::uint32_t> indices; ///< three per triangle, counter-clockwise front faces

    std::size_t vertexCount() const noexcept { return positions.size(); }
    std::size_t triangleCount() const noexcept { return indices.size() / 3; }

    /// Throws lightskin::Error naming `sourceName` when: counts disagree, an index is out of
    /// range, the index count is not a multiple of 3, or a position/normal is not finite.
    void validate(const std::string& sourceName) const;
    /// Area-weighted vertex normals from the triangles (for meshes without normals).
    void computeVertexNormals();
};

} // namespace lightskin
