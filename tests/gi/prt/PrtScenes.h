#pragma once
// Small analytic scenes for the multi-scale PRT tests: quads subdivided into grids (quadGrid of
// ../lights/TestMeshes.h), boxes of them. World = model space (identity placement), metres, counter-clockwise
// front faces.
#include "common/TestMeshes.h"

#include <lightskin/gi/common/IndirectIllumination.h>

#include <glm/geometric.hpp>

#include <deque>
#include <vector>

namespace lightskin::test::prt {

using test::quadGrid; // the grid builder shared with the light-side tests (TestMeshes.h)

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
