#pragma once
// Uploads a TriangleMesh the way the renderer does (attribute 0 position, 1 normal, uint indices)
// for GL tests of the light-side stages. Needs a current GL context.
#include <lightskin/core/TriangleMesh.h>
#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gl/Objects.h>

#include <vector>

namespace lightskin::test {

struct GpuTestMesh {
    gl::Buffer vertices, indices;
    gl::VertexArray vertexArray;
    gi::GpuMeshView view;

    static GpuTestMesh upload(const TriangleMesh& mesh) {
        GpuTestMesh out;
        std::vector<float> interleaved;
        for (std::size_t i = 0; i < mesh.vertexCount(); ++i) {
            interleaved.insert(interleaved.end(), {mesh.positions[i].x, mesh.positions[i].y, mesh.positions[i].z});
            interleaved.insert(interleaved.end(), {mesh.normals[i].x, mesh.normals[i].y, mesh.normals[i].z});
        }
        out.vertices = gl::Buffer::create(GLsizeiptr(interleaved.size() * sizeof(float)), interleaved.data(), 0);
        out.indices = gl::Buffer::create(GLsizeiptr(mesh.indices.size() * sizeof(std::uint32_t)), mesh.indices.data(), 0);
        out.vertexArray = gl::VertexArray::create();
        const GLuint vao = out.vertexArray.id();
        glVertexArrayVertexBuffer(vao, 0, out.vertices.id(), 0, 6 * sizeof(float));
        glVertexArrayElementBuffer(vao, out.indices.id());
        for (GLuint attribute = 0; attribute < 2; ++attribute) {
            glEnableVertexArrayAttrib(vao, attribute);
            glVertexArrayAttribFormat(vao, attribute, 3, GL_FLOAT, GL_FALSE, attribute * 3 * sizeof(float));
            glVertexArrayAttribBinding(vao, attribute, 0);
        }
        out.view = {vao, std::uint32_t(mesh.indices.size()), std::uint32_t(mesh.vertexCount())};
        return out;
    }
};

} // namespace lightskin::test
