#include <lightskin/roomlight/SphericalHarmonics.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace lightskin::roomlight {
namespace {
// The normalisation constants of the header's table.
const double kY00 = 0.5 * std::sqrt(1.0 / kPi);
const double kY1 = std::sqrt(3.0 / (4.0 * kPi));
const double kY2Mixed = 0.5 * std::sqrt(15.0 / kPi);
const double kY20 = 0.25 * std::sqrt(5.0 / kPi);
const double kY22 = 0.25 * std::sqrt(15.0 / kPi);

int bandOf(int k) noexcept { return k == 0 ? 0 : (k < 4 ? 1 : 2); }
} // namespace

ShBasis shBasis(const glm::dvec3& d) noexcept {
    return {kY00,
            kY1 * d.y,
            kY1 * d.z,
            kY1 * d.x,
            kY2Mixed * d.x * d.y,
            kY2Mixed * d.y * d.z,
            kY20 * (3.0 * d.z * d.z - 1.0),
            kY2Mixed * d.x * d.z,
            kY22 * (d.x * d.x - d.y * d.y)};
}

double irradianceConvolution(int k) noexcept {
    static constexpr std::array<double, 3> kBand{kPi, 2.0 * kPi / 3.0, kPi / 4.0};
    return kBand[static_cast<std::size_t>(bandOf(k))];
}

glm::dvec3 evaluateSh(const ShRgb& coefficients, const glm::dvec3& normal) noexcept {
    const ShBasis y = shBasis(normal);
    glm::dvec3 sum{0.0};
    for (std::size_t k = 0; k < kShCount; ++k) sum += coefficients[k] * y[k];
    return sum;
}

void addDirectionalLight(ShRgb& irradiance, const glm::dvec3& towardLight,
                         const glm::dvec3& irradianceFacing) noexcept {
    const ShBasis y = shBasis(towardLight);
    for (std::size_t k = 0; k < kShCount; ++k)
        irradiance[k] += irradianceConvolution(static_cast<int>(k)) * y[k] * irradianceFacing;
}

ShDominantLight extractDominantLight(const ShRgb& irradiance) noexcept {
    ShRgb radiance{};
    for (std::size_t k = 0; k < kShCount; ++k) radiance[k] = irradiance[k] / irradianceConvolution(static_cast<int>(k));
    const auto luminance = [](const glm::dvec3& rgb) { return (rgb.x + rgb.y + rgb.z) / 3.0; };
    const glm::dvec3 band1{luminance(radiance[3]), luminance(radiance[1]), luminance(radiance[2])};
    ShDominantLight light;
    const double length = glm::length(band1);
    if (!(length > 0.0) || !std::isfinite(length)) return light;
    light.towardLight = band1 / length;
    const ShBasis y = shBasis(light.towardLight);
    glm::dvec3 numerator{0.0};
    for (std::size_t k = 1; k < kShCount; ++k) numerator += radiance[k] * y[k];
    light.irradianceFacing = glm::max(numerator * (kPi / 2.0), glm::dvec3(0.0));
    return light;
}

} // namespace lightskin::roomlight
