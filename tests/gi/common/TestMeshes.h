#pragma once
// Analytic meshes for the sparse-point and ground-truth tests, and a minimal ASCII PLY reader
// (vertex x y z first, triangle faces) for the Stanford bunny. Model space, metres, CCW front faces.
#include <lightskin/core/TriangleMesh.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

namespace lightskin::test {

/// A cells x cells grid of quads with one normal: vertex (i, j) at index j (cells + 1) + i and at position(s, t),
/// s = i / cells, t = j / cells; two counter-clockwise triangles per quad ((i, j), (i + 1, j), (i + 1, j + 1)) and
/// ((i, j), (i + 1, j + 1), (i, j + 1)), front side where `normal` points when s, t run along its right hand.
template <typename Position>
TriangleMesh gridMesh(int cells, glm::vec3 normal, Position position) {
    TriangleMesh mesh;
    for (int j = 0; j <= cells; ++j)
        for (int i = 0; i <= cells; ++i) {
            mesh.positions.push_back(position(float(i) / float(cells), float(j) / float(cells)));
            mesh.normals.push_back(normal);
        }
    const auto at = [&](int i, int j) { return std::uint32_t(j * (cells + 1) + i); };
    for (int j = 0; j < cells; ++j)
        for (int i = 0; i < cells; ++i) {
            mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    return mesh;
}

/// origin + [0, 1]^2 spanned by u, v in cells x cells quads; normal = normalize(u x v).
inline TriangleMesh quadGrid(glm::vec3 origin, glm::vec3 u, glm::vec3 v, int cells) {
    return gridMesh(cells, glm::normalize(glm::cross(u, v)), [&](float s, float t) { return origin + u * s + v * t; });
}

/// Square grid in the z = 0 plane, [-size/2, size/2]^2, cells x cells quads, normals +z.
inline TriangleMesh planeGrid(float size, int cells, float z = 0.0f) {
    // size (s - 1/2) as before quadGrid shared the grid: the other form moves positions by an ulp, and
    // ImperfectVolumesExtremeGLTest.TemporalBlend's 1e-5 bound has no margin for that (1.015e-5 measured).
    return gridMesh(cells, {0.0f, 0.0f, 1.0f},
                    [&](float s, float t) { return glm::vec3(size * (s - 0.5f), size * (t - 0.5f), z); });
}

/// UV sphere of `radius` around the origin with outward normals.
inline TriangleMesh uvSphere(float radius, int rings, int segments) {
    TriangleMesh mesh;
    for (int r = 0; r <= rings; ++r) {
        const double theta = std::numbers::pi * r / rings;
        for (int s = 0; s <= segments; ++s) {
            const double phi = 2.0 * std::numbers::pi * s / segments;
            const glm::vec3 n(float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)),
                              float(std::cos(theta)));
            mesh.positions.push_back(radius * n);
            mesh.normals.push_back(n);
        }
    }
    const auto at = [&](int r, int s) { return std::uint32_t(r * (segments + 1) + s); };
    for (int r = 0; r < rings; ++r)
        for (int s = 0; s < segments; ++s) {
            if (r != 0) mesh.indices.insert(mesh.indices.end(), {at(r, s), at(r + 1, s), at(r, s + 1)});
            if (r != rings - 1) mesh.indices.insert(mesh.indices.end(), {at(r, s + 1), at(r + 1, s), at(r + 1, s + 1)});
        }
    return mesh;
}

/// Axis-aligned cube [-h, h]^3 with flat faces (24 vertices, 12 triangles).
inline TriangleMesh cube(float h) {
    TriangleMesh mesh;
    const glm::vec3 normals[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (const glm::vec3& n : normals) {
        const glm::vec3 u = std::abs(n.x) > 0.5f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
        const glm::vec3 v = glm::cross(n, u);
        const auto base = std::uint32_t(mesh.positions.size());
        for (const auto& [a, b] : {std::pair{-1.f, -1.f}, {1.f, -1.f}, {1.f, 1.f}, {-1.f, 1.f}}) {
            mesh.positions.push_back(h * (n + a * u + b * v));
            mesh.normals.push_back(n);
        }
        mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    }
    return mesh;
}

/// Minimal ASCII PLY reader: the first three vertex properties are x y z; faces are triangles.
inline TriangleMesh readAsciiPly(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error("cannot open " + path);
    std::string line;
    std::size_t vertices = 0, faces = 0;
    int vertexProperties = 0;
    bool inVertex = false;
    while (std::getline(in, line) && line != "end_header") {
        std::istringstream words(line);
        std::string word, kind;
        words >> word;
        if (word == "element") {
            words >> kind;
            inVertex = kind == "vertex";
            (inVertex ? vertices : faces) = [&] {
                std::size_t n = 0;
                words >> n;
                return n;
            }();
        } else if (word == "property" && inVertex) {
            ++vertexProperties;
        }
    }
    TriangleMesh mesh;
    for (std::size_t i = 0; i < vertices; ++i) {
        std::getline(in, line);
        std::istringstream values(line);
        glm::vec3 p;
        values >> p.x >> p.y >> p.z;
        mesh.positions.push_back(p);
    }
    // bun_zipper_res4.ply keeps two removed faces as "comment" lines inside the face list.
    for (std::size_t i = 0; i < faces && std::getline(in, line);) {
        if (line.starts_with("comment")) continue;
        std::istringstream values(line);
        int count = 0;
        std::uint32_t a = 0, b = 0, c = 0;
        values >> count >> a >> b >> c;
        if (count != 3 || !values) throw std::runtime_error("non-triangle face in " + path);
        mesh.indices.insert(mesh.indices.end(), {a, b, c});
        ++i;
    }
    (void)vertexProperties;
    mesh.computeVertexNormals();
    return mesh;
}

} // namespace lightskin::test
