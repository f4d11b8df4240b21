#include <lightskin/gi/common/NullIndirectIllumination.h>

#include <epoxy/gl.h>

namespace lightskin::gi {

void NullIndirectIllumination::render(const ValSetView&, std::span<const MeshInstance>, const GBufferView&,
                                      const ViewParameters&, std::uint32_t targetTexture) {
    const float zero[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    glClearTexImage(targetTexture, 0, GL_RGBA, GL_FLOAT, zero);
}

} // namespace lightskin::gi
