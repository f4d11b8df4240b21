#pragma once
// Multi-scale PRT's small scale (paper 004, sec. 9): the instances' occlusion or normal maps as GL textures and
// which of them each instance's shading uses. The choice and its formulas: gi/prt/include/lightskin/gi/prt/MultiscalePrt.h,
// "Small scale". Private to gi.
#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gl/Objects.h>

#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

namespace lightskin::gi::detail {

/// What prt_shade.frag evaluates for an instance (its uniform uSmallScaleMode).
enum class SmallScaleMode : int {
    Off = 0,          ///< no map (or no texture coordinates): factor 1
    OcclusionMap = 1, ///< 1 + strength (R - 1)
    NormalMap = 2,    ///< (1 + cos alpha) / 2, alpha between the mapped normal and the mean surface's
};

struct SmallScaleBinding {
    SmallScaleMode mode = SmallScaleMode::Off;
    std::uint32_t texture = 0; ///< GL name, owned by PrtSmallScale; 0 when off
    float factor = 1.0f;       ///< occlusion strength or normal scale
};

/// A map file decoded for the GPU: the whole image, top row first in the file, uploaded bottom row first (texture
/// coordinate v = 0 is the bottom row after assimp, as the renderer's diffuse textures), 16-bit unsigned normalised
/// (8-bit files are widened exactly: v / 255 = 257 v / 65535), mipmapped, linear filtering, repeat. Occlusion maps
/// keep the red channel (GL_R16), normal maps red, green, blue (GL_RGBA16, a = 1). Throws lightskin::Error naming
/// the file and the cause (readImageFile's errors: missing, not PNG/TIFF/JPEG, corrupt).
gl::Texture loadSmallScaleTexture(const std::filesystem::path& file, SmallScaleMode mode);

/// Move-only; built in prepare(), read per frame without allocation.
class PrtSmallScale {
public:
    /// Decodes every instance's map once per file. An occlusion map wins over a normal map (both describe the same
    /// detail; applying both would count its occlusion twice). A map on a mesh without texture coordinates is
    /// logged and left off. Throws lightskin::Error naming the file and the cause.
    static PrtSmallScale create(std::span<const MeshInstance> instances);
    const SmallScaleBinding& binding(std::size_t instance) const { return bindings_.at(instance); }

private:
    std::vector<gl::Texture> textures_;
    std::vector<SmallScaleBinding> bindings_;
};

} // namespace lightskin::gi::detail
