#include <lightskin/core/Error.h>
#include <lightskin/core/TriangleMesh.h>

#include <glm/geometric.hpp>

#include <cmath>

namespace lightskin {

namespace {
bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
} // namespace

void TriangleMesh::validate(const std::string& sourceName) const {
    const auto fail = [&](const std::string& cause) { throw Error(sourceName, std::nullopt, cause); };
    if (positions.empty()) fail("mesh has no vertices");
    if (indices.empty() || indices.size() % 3 != 0)
        fail("index count " + std::to_string(indices.size()) + " is not a positive multiple of 3");
    if (normals.size() != positions.size())
        fail(std::to_string(normals.size()) + " normals for " + std::to_string(positions.size()) + " vertices");
    if (!texcoords.empty() && texcoords.size() != positions.size())
        fail(std::to_string(texcoords.size()) + " texture coordinates for " + std::to_string(positions.size()) + " vertices");
    for (std::size_t i = 0; i < positions.size(); ++i) {
        if (!finite(positions[i])) fail("vertex " + std::to_string(i) + " has a non-finite position");
        if (!finite(normals[i])) fail("vertex " + std::to_string(i) + " has a non-finite normal");
    }
    for (std::size_t i = 0; i < indices.size(); ++i)
        if (indices[i] >= positions.size())
            fail("triangle " + std::to_string(i / 3) + " refers to vertex " + std::to_string(indices[i]) + " of " +
                 std::to_string(positions.size()));
}

void TriangleMesh::computeVertexNormals() {
    normals.assign(positions.size(), glm::vec3(0.0f));
    for (std::size_t t = 0; t + 2 < indices.size(); t += 3) {
        const glm::vec3& a = positions[indices[t]];
        const glm::vec3& b = positions[indices[t + 1]];
        const glm::vec3& c = positions[indices[t + 2]];
        const glm::vec3 areaWeighted = glm::cross(b - a, c - a); // length = 2 * area
        for (int k = 0; k < 3; ++k) normals[indices[t + std::size_t(k)]] += areaWeighted;
    }
    for (glm::vec3& n : normals) {
        const float length = glm::length(n);
        // Vertices only on degenerate triangles get +z rather than NaN; validate() stays happy.
        n = length > 0.0f ? n / length : glm::vec3(0.0f, 0.0f, 1.0f);
    }
}

} // namespace lightskin
