#pragma once
// A minimal G-buffer of the virtual content and GPU copies of meshes, for the GI tests and
// benchmarks (the renderer in render/ has its own, full one). Layout as GBufferView documents:
// RGBA32F world position (w = 1 where covered), RGBA32F world normal (w = 1 on back faces, whose normal
// is turned toward the viewer, as the renderer's), RGBA32F albedo, RGBA32F
// specular (rgb f_s, a = k), DEPTH_COMPONENT32F depth. Needs a current GL 4.5 context.

#include <lightskin/core/TriangleMesh.h>
#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gl/Objects.h>

#include <memory>
#include <span>

namespace lightskin::gi {

/// A TriangleMesh on the GPU in the GpuMeshView layout (attribute 0 position, 1 normal, 2 texcoord when the mesh
/// has them).
class UploadedMesh {
public:
    static UploadedMesh create(const TriangleMesh& mesh);
    GpuMeshView view() const noexcept { return view_; }

private:
    gl::VertexArray vertexArray_;
    gl::Buffer positions_, normals_, texcoords_, indices_;
    GpuMeshView view_;
};

class SimpleGBuffer {
public:
    static SimpleGBuffer create(int width, int height);
    /// Clears and rasterises the instances (their gpu views) seen through clip_T_world.
    void render(std::span<const MeshInstance> instances, const glm::mat4& clip_T_world);
    GBufferView view() const noexcept;
    const gl::Texture& position() const noexcept { return position_; }
    const gl::Texture& normal() const noexcept { return normal_; }

private:
    gl::Texture position_, normal_, albedo_, specular_, depth_;
    gl::Framebuffer framebuffer_;
    gl::Program program_;
    int width_ = 0, height_ = 0;
};

} // namespace lightskin::gi
