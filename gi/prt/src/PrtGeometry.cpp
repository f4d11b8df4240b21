#include "PrtGeometry.h"

#include <lightskin/core/Error.h>

#include <glm/geometric.hpp>

#include <limits>
#include <string>

namespace lightskin::gi::detail {

PrtGeometry PrtGeometry::create(std::span<const MeshInstance> instances) {
    PrtGeometry out;
    std::vector<RayMesh> meshes;
    meshes.reserve(instances.size());
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    glm::dvec3 albedoSum(0.0);
    double areaSum = 0.0;
    for (std::size_t m = 0; m < instances.size(); ++m) {
        LIGHTSKIN_ASSERT(instances[m].mesh != nullptr,
                         "lightskin::gi::detail::PrtGeometry::create(): instance without a mesh");
        const TriangleMesh& mesh = *instances[m].mesh;
        mesh.validate("multiscale-prt mesh " + std::to_string(m));
        meshes.push_back({&mesh, glm::dmat4(instances[m].world_T_model)});
        out.firstTriangle.push_back(std::uint32_t(out.triangles.size()));
        out.albedo.push_back(instances[m].material.diffuseAlbedo);
        std::vector<glm::vec3> world(mesh.vertexCount());
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
            world[v] = glm::vec3(instances[m].world_T_model * glm::vec4(mesh.positions[v], 1.0f));
            lo = glm::min(lo, world[v]);
            hi = glm::max(hi, world[v]);
        }
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
            PrtTriangle tri;
            tri.a = world[mesh.indices[3 * t]];
            tri.b = world[mesh.indices[3 * t + 1]];
            tri.c = world[mesh.indices[3 * t + 2]];
            const glm::vec3 cross = glm::cross(tri.b - tri.a, tri.c - tri.a);
            const float length = glm::length(cross);
            tri.area = 0.5f * length;
            tri.normal = length > 0.0f ? cross / length : glm::vec3(0.0f, 0.0f, 1.0f);
            tri.instance = std::uint32_t(m);
            out.triangles.push_back(tri);
            albedoSum += double(tri.area) * glm::dvec3(instances[m].material.diffuseAlbedo);
            areaSum += double(tri.area);
        }
    }
    out.rays = TriangleRayScene::create(meshes, "multiscale-prt");
    out.diagonal = out.triangles.empty() ? 0.0f : glm::length(hi - lo);
    out.averageAlbedo = areaSum > 0.0 ? glm::vec3(albedoSum / areaSum) : glm::vec3(0.0f);
    return out;
}

PrtHit PrtGeometry::intersect(const glm::vec3& origin, const glm::vec3& direction, float tnear, float tfar) const {
    PrtHit hit;
    const auto rayHit = rays.intersect(glm::dvec3(origin), glm::dvec3(direction), double(tnear), double(tfar));
    if (!rayHit) return hit;
    const PrtTriangle& tri = triangles[firstTriangle[rayHit->mesh] + rayHit->triangle];
    hit.hit = true;
    hit.distance = float(rayHit->t);
    hit.normal = tri.normal;
    hit.albedo = albedo[tri.instance];
    hit.frontFace = glm::dot(direction, tri.normal) < 0.0f;
    return hit;
}

} // namespace lightskin::gi::detail
