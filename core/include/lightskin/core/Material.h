#pragma once
// The paper's Phong material (LightSkin eq. 4, 5, 10): diffuse albedo, specular reflectance f_s
// and exponent k. Linear RGB, unitless reflectances in [0,1]. Optional small-scale maps (glTF
// occlusionTexture / normalTexture, OBJ norm) for the small-scale ambient occlusion of multi-scale PRT
// (gi/prt/include/lightskin/gi/prt/MultiscalePrt.h); texture paths are absolute, empty = none.

#include <glm/vec3.hpp>

#include <string>

namespace lightskin {

struct Material {
    glm::vec3 diffuseAlbedo{0.8f};  ///< rho_d; the BRDF is rho_d / pi
    glm::vec3 specularAlbedo{0.0f}; ///< f_s; zero = no glossy channel needed for this material
    float specularExponent = 1.0f;  ///< k >= 1 (Phong exponent)
    std::string diffuseTexture;     ///< optional texture path (sRGB), multiplies diffuseAlbedo
    /// Optional ambient-occlusion map of the surface detail the mesh does not model (glTF occlusionTexture):
    /// linear, the red channel in [0, 1] (1 = open). Applied as 1 + occlusionStrength (texel - 1).
    std::string occlusionTexture;
    float occlusionStrength = 1.0f; ///< glTF occlusionTexture.strength, in [0, 1]
    /// Optional tangent-space normal map (glTF normalTexture, OBJ norm): linear RGB, n = 2 texel - 1, its x
    /// and y multiplied by normalScale before normalising (glTF normalTexture.scale, OBJ -bm).
    std::string normalTexture;
    float normalScale = 1.0f;

    bool hasSpecular() const noexcept {
        return specularAlbedo.x > 0.0f || specularAlbedo.y > 0.0f || specularAlbedo.z > 0.0f;
    }
};

} // namespace lightskin
