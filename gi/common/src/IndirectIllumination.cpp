#include <lightskin/gi/common/IndirectIllumination.h>

#include <epoxy/gl.h>
#include <glm/mat3x3.hpp>

namespace lightskin::gi {

void setFrontFaceFor(const glm::mat4& world_T_model) {
    glFrontFace(glm::determinant(glm::mat3(world_T_model)) < 0.0f ? GL_CW : GL_CCW);
}

} // namespace lightskin::gi
