#pragma once
// Small analytic scenes for the multi-scale PRT tests: quads subdivided into grids, boxes of them.
// World = model space (identity placement), metres, counter-clockwise front faces.
#include <lightskin/gi/IndirectIllumination.h>

#include <glm/geometric.hpp>

#include <deque>
#include <vector>

namespace lightskin::test::prt {

/// origin + [0, 1]^2 spanned by u, v in cells x cells quads; normal = normalize(u x v).
inline TriangleMesh quadGrid(glm::vec3 origin, glm::vec3 u, glm::vec3 v, int cells) {
    TriangleMesh mesh;
    const glm::vec3 n = glm::normalize(glm::cross(u, v));
    for (int j = 0; j <= cells; ++j)
        for (int i = 0; i <= cells; ++i) {
            mesh.positions.push_back(origin + u * (float(i) / float(cells)) + v * (float(j) / float(cells)));
            mesh.normals.push_back(n);
        }
    const auto at = [&](int i, int j) { return std::uint32_t(j * (cells + 1) + i); };
    for (int j = 0; j < cells; ++j)
        for (int i = 0; i < cells; ++i) {
            mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    return mesh;
}

/// Meshes with stable addresses and their instances.
struct PrtScene {
    std::deque<TriangleMesh> meshes;
    std::vector<gi::MeshInstance> instances;
    void add(TriangleMesh mesh, glm::vec3 albedo) {
        meshes.push_back(std::move(mesh));
        gi::MeshInstance instance;
        instance.meshId = std::uint32_t(instances.size());
        instance.mesh = &meshes.back();
        instance.material.diffuseAlbedo = albedo;
        instances.push_back(instance);
    }
};

/// The unit cube [0, 1]^3 seen from inside (normals inward), one instance per face in the order floor
/// (z = 0), x = 0, x = 1, y = 0, y = 1, ceiling (z = 1); `withCeiling` false leaves the top open.
inline PrtScene insideBox(int cells, glm::vec3 albedo, bool withCeiling, glm::vec3 floorAlbedo = glm::vec3(-1.0f)) {
    PrtScene scene;
    scene.add(quadGrid({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, cells), floorAlbedo.x >= 0.0f ? floorAlbedo : albedo);
    scene.add(quadGrid({0, 0, 0}, {0, 1, 0}, {0, 0, 1}, cells), albedo);
    scene.add(quadGrid({1, 0, 0}, {0, 0, 1}, {0, 1, 0}, cells), albedo);
    scene.add(quadGrid({0, 0, 0}, {0, 0, 1}, {1, 0, 0}, cells), albedo);
    scene.add(quadGrid({0, 1, 0}, {1, 0, 0}, {0, 0, 1}, cells), albedo);
    if (withCeiling) scene.add(quadGrid({0, 0, 1}, {0, 1, 0}, {1, 0, 0}, cells), albedo);
    return scene;
}

} // namespace lightskin::test::prt
