#pragma once
// A TriangleMesh on the GPU in the layout gi::GpuMeshView documents: one vertex array with
// attribute 0 = position (vec3), 1 = normal (vec3), 2 = texcoord (vec2; constant (0,0) when the mesh
// has none) and a GL_UNSIGNED_INT element buffer. Move-only; owns its buffers. Needs a current context.

#include <lightskin/core/TriangleMesh.h>
#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gl/Objects.h>

namespace lightskin::render {

class GpuMesh {
public:
    GpuMesh() = default;
    /// Uploads `mesh` (validated first: throws lightskin::Error naming `sourceName`). `deformable`: positions and
    /// normals can be replaced later (updateVertices), for meshes that deform per frame.
    static GpuMesh create(const TriangleMesh& mesh, const std::string& sourceName, bool deformable = false);
    /// Replaces the positions and normals with `mesh`'s (same vertex count as at create(), which had
    /// `deformable`): glNamedBufferSubData into the existing buffers, no allocation.
    void updateVertices(const TriangleMesh& mesh);

    gi::GpuMeshView view() const noexcept { return {vertexArray_.id(), indexCount_, vertexCount_}; }
    void draw() const;

private:
    gl::Buffer positions_, normals_, texcoords_, indices_;
    gl::VertexArray vertexArray_;
    std::uint32_t indexCount_ = 0, vertexCount_ = 0;
    bool deformable_ = false;
};

} // namespace lightskin::render
