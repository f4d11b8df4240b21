#include <lightskin/core/Error.h>
#include <lightskin/render/GpuMesh.h>

namespace lightskin::render {

namespace {
template <class T>
GLsizeiptr bytes(const std::vector<T>& v) {
    return GLsizeiptr(v.size() * sizeof(T));
}
} // namespace

GpuMesh GpuMesh::create(const TriangleMesh& mesh, const std::string& sourceName, bool deformable) {
    mesh.validate(sourceName);
    GpuMesh out;
    const GLbitfield vertexFlags = deformable ? GL_DYNAMIC_STORAGE_BIT : 0;
    out.positions_ = gl::Buffer::create(bytes(mesh.positions), mesh.positions.data(), vertexFlags);
    out.normals_ = gl::Buffer::create(bytes(mesh.normals), mesh.normals.data(), vertexFlags);
    out.deformable_ = deformable;
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

void GpuMesh::updateVertices(const TriangleMesh& mesh) {
    LIGHTSKIN_ASSERT(deformable_ && mesh.positions.size() == vertexCount_ && mesh.normals.size() == vertexCount_,
                     "a deformable mesh with the vertex count it was created with");
    glNamedBufferSubData(positions_.id(), 0, bytes(mesh.positions), mesh.positions.data());
    glNamedBufferSubData(normals_.id(), 0, bytes(mesh.normals), mesh.normals.data());
}

void GpuMesh::draw() const {
    glBindVertexArray(vertexArray_.id());
    glDrawElements(GL_TRIANGLES, GLsizei(indexCount_), GL_UNSIGNED_INT, nullptr);
    glBindVertexArray(0);
}

} // namespace lightskin::render
