#include <lightskin/render/NullIndirectIllumination.h>

#include <epoxy/gl.h>

namespace lightskin::render {

void NullIndirectIllumination::render(const gi::ValSetView&, std::span<const gi::MeshInstance>, const gi::GBufferView&,
                                      const gi::ViewParameters&, std::uint32_t targetTexture) {
    const float zero[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    glClearTexImage(targetTexture, 0, GL_RGBA, GL_FLOAT, zero);
}

} // namespace lightskin::render
