#pragma once
// A small GPU scene for the LightSkin GL tests: meshes with their sparse-point counts, a
// SimpleGBuffer, an RGBA32F output texture and a camera looking at `target` from `eye` (world
// metres, z up). Build with add() ... upload(), then make techniques with technique(). Needs a
// current GL context (the GlTest fixture); the rig owns every GL object it creates.
#include <lightskin/core/Material.h>
#include <lightskin/core/TriangleMesh.h>
#include <lightskin/gi/lightskin/LightSkinIllumination.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gi/common/SparsePointSampler.h>
#include <lightskin/gi/common/VertexSparsePoints.h>
#include <lightskin/gl/Objects.h>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace lightskin::test {

struct GpuRig {
    std::vector<TriangleMesh> meshes;
    std::vector<std::size_t> sparseCounts;
    std::vector<gi::UploadedMesh> gpu;
    std::vector<gi::MeshInstance> instances;
    glm::vec3 eye{1.6f, -1.8f, 1.5f};
    glm::vec3 target{0.0f, 0.0f, 0.3f};
    float sceneScale = 1.0f; ///< scales the near and far planes (0.01 and 100 m at 1)
    int width = 64, height = 64;
    /// true: sparse points from the production farthest-point sampler (gi::sampleSparsePoints,
    /// seed 1); false: the test helper's vertex subset (gi::sparsePointsFromVertices), which puts
    /// points exactly on chosen vertices (some analytic tests rely on that).
    bool productionSampler = false;
    gi::SimpleGBuffer gbuffer;
    gl::Texture output;

    void add(TriangleMesh mesh, const glm::mat4& world_T_model, const Material& material, std::size_t sparseCount) {
        meshes.push_back(std::move(mesh));
        sparseCounts.push_back(sparseCount);
        gi::MeshInstance instance;
        instance.meshId = std::uint32_t(instances.size());
        instance.world_T_model = world_T_model;
        instance.material = material;
        instances.push_back(instance);
    }
    /// Uploads the meshes and creates the G-buffer and output at width x height.
    void upload() {
        gpu.clear();
        for (std::size_t i = 0; i < meshes.size(); ++i) {
            gpu.push_back(gi::UploadedMesh::create(meshes[i]));
            instances[i].mesh = &meshes[i];
            instances[i].gpu = gpu[i].view();
        }
        gbuffer = gi::SimpleGBuffer::create(width, height);
        output = gl::Texture::create2D(GL_RGBA32F, width, height);
    }
    gi::ViewParameters view() const {
        const glm::mat4 projection =
            glm::perspective(0.8f, float(width) / float(height), 0.01f * sceneScale, 100.0f * sceneScale);
        return {projection * glm::lookAt(eye, target, glm::vec3(0, 0, 1)), eye};
    }
    /// The sparseCounts[i] sparse points of mesh i (see productionSampler).
    gi::SparsePointSet sparsePoints(std::size_t i) const {
        if (!productionSampler) return gi::sparsePointsFromVertices(meshes[i], sparseCounts[i]);
        gi::SparsePointSettings settings;
        settings.pointCount = int(sparseCounts[i]);
        return gi::sampleSparsePoints(meshes[i], settings, "test mesh " + std::to_string(i));
    }
    /// sparsePoints() of each instance's mesh. Valid while the rig lives.
    gi::SparsePointProvider provider() const {
        return [this](const gi::MeshInstance& instance) { return sparsePoints(instance.meshId); };
    }
    /// A prepared technique with provider()'s sparse points.
    std::unique_ptr<gi::LightSkinIllumination> technique(const gi::LightSkinSettings& settings) const {
        auto t = gi::LightSkinIllumination::create(settings, provider());
        t->prepare(instances);
        return t;
    }
};

} // namespace lightskin::test
