#pragma once
// The paper's Phong material (LightSkin eq. 4, 5, 10): diffuse albedo, specular reflectance f_s
// and exponent k. Linear RGB, unitless reflectances in [0,1].

#include <glm/vec3.hpp>

#include <string>

namespace lightskin {

struct Material {
    glm::vec3 diffuseAlbedo{0.8f};   ///< rho_d; the BRDF is rho_d / pi
    glm::vec3 specularAlbedo{0.0f};  ///< f_s; zero = no glossy channel needed for this material
    float specularExponent = 1.0f;   ///< k >= 1 (Phong exponent)
    std::string diffuseTexture;      ///< optional texture path (sRGB), multiplies diffuseAlbedo

    bool hasSpecular() const noexcept { return specularAlbedo.x > 0.0f || specularAlbedo.y > 0.0f || specularAlbedo.z > 0.0f; }
};

} // namespace lightskin
