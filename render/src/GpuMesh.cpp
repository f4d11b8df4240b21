#include <lightskin/render/GpuMesh.h>

namespace lightskin::render {

GpuMesh GpuMesh::create(const TriangleMesh& mesh, const std::string& sourceName) {
    mesh.validate(sourceName);
    GpuMesh out;
    const auto bytes = [](const auto& v) { return GLsizeiptr(v.size() * sizeof(v[0])); };
    out.positions_ = gl::Buffer::create(bytes(mesh.positions), mesh.positions.data(), 0);
    out.normals_ = gl::Buffer::create(bytes(mesh.normals), mesh.normals.data(), 0);
    if (!mesh.texcoords.empty()) out.texcoords_ = gl::Buffer::create(bytes(mesh.texcoords), mesh.texcoords.data(), 0);
    out.indices_ = gl::Buffer::create(bytes(mesh.indices), mesh.indices.data(), 0);
    out.vertexArray_ = gl::VertexArray::create();
    const GLuint vao = out.vertexArray_.id();
    glVertexArrayVertexBuffer(vao, 0, out.positions_.id(), 0, sizeof(glm::vec3));
    glVertexArrayAttribFormat(vao, 0, 3, GL_FLOAT, GL_FALSE, 0);
    glVertexArrayAttribBinding(vao, 0, 0);
    glEnableVertexArrayAttrib(vao, 0);
    glVertexArrayVertexBuffer(vao, 1, out.normals_.id(), 0, sizeof(glm::vec3));
    glVertexArrayAttribFormat(vao, 1, 3, GL_FLOAT, GL_FALSE, 0);
    glVertexArrayAttribBinding(vao, 1, 1);
    glEnableVertexArrayAttrib(vao, 1);
    if (out.texcoords_) {
        glVertexArrayVertexBuffer(vao, 2, out.texcoords_.id(), 0, sizeof(glm::vec2));
        glVertexArrayAttribFormat(vao, 2, 2, GL_FLOAT, GL_FALSE, 0);
        glVertexArrayAttribBinding(vao, 2, 2);
        glEnableVertexArrayAttrib(vao, 2);
    } else {
        glDisableVertexArrayAttrib(vao, 2);
        glVertexAttrib2f(2, 0.0f, 0.0f);
    }
    glVertexArrayElementBuffer(vao, out.indices_.id());
    out.indexCount_ = std::uint32_t(mesh.indices.size());
    out.vertexCount_ = std::uint32_t(mesh.positions.size());
    return out;
}

void GpuMesh::draw() const {
    glBindVertexArray(vertexArray_.id());
    glDrawElements(GL_TRIANGLES, GLsizei(indexCount_), GL_UNSIGNED_INT, nullptr);
    glBindVertexArray(0);
}

} // namespace lightskin::render
