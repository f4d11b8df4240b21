#include <lightskin/gi/common/IndirectIllumination.h>

#include <epoxy/gl.h>
#include <glm/mat3x3.hpp>

namespace lightskin::gi {

void setFrontFaceFor(const glm::mat4& world_T_model) {
    glFrontFace(glm::determinant(glm::mat3(world_T_model)) < 0.0f ? GL_CW : GL_CCW);
}

const std::vector<std::uint32_t>& IndirectIllumination::vertexOffsets() const noexcept {
    static const std::vector<std::uint32_t> none;
    return none;
}

} // namespace lightskin::gi
