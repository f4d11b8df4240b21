// Multi-scale PRT's per-frame CPU part (sec. 10 of the paper): the VALs' irradiance at the entry and exit
// points and the compressed transfer. Compiled with -O3 and reassociation (gi/CMakeLists.txt) so that the
// VAL loops vectorise; formulas: gi/include/lightskin/gi/MultiscalePrt.h.
#include <lightskin/core/Error.h>
#include <lightskin/gi/MultiscalePrt.h>

#include <glm/geometric.hpp>

#include <numbers>

namespace lightskin::gi {

namespace {
constexpr float kPi = std::numbers::pi_v<float>;

// Unoccluded disc form factor of every VAL at p (LightSkin eq. 3): phi cos_j cos_p / (pi d^2 + A).
glm::vec3 valIrradiance(std::span<const VirtualAreaLight> vals, const glm::vec3& p, const glm::vec3& n) {
    glm::vec3 sum(0.0f);
    for (const VirtualAreaLight& val : vals) {
        if (!(val.area > 0.0f)) continue; // also skips NaN areas
        const glm::vec3 d = val.position - p;
        const float d2 = glm::dot(d, d);
        const float cosP = glm::dot(n, d), cosJ = -glm::dot(val.normal, d); // both times |d|
        if (!(cosP > 0.0f) || !(cosJ > 0.0f)) continue;
        sum += val.flux * (cosP * cosJ / (d2 * (kPi * d2 + val.area)));
    }
    return sum;
}
} // namespace

void prtEntryIrradianceInto(const PrtData& data, std::span<const VirtualAreaLight> vals,
                            std::span<glm::vec3> entryIrradiance) {
    LIGHTSKIN_ASSERT(entryIrradiance.size() == data.entryCount(),
                     "lightskin::gi::prtEntryIrradianceInto(): one per entry");
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t e = 0; e < std::ptrdiff_t(data.entryCount()); ++e)
        entryIrradiance[std::size_t(e)] =
            data.entryObscurance[std::size_t(e)] *
            valIrradiance(vals, data.entryPositions[std::size_t(e)], data.entryNormals[std::size_t(e)]);
}

void prtExitIrradianceInto(const PrtData& data, std::span<const VirtualAreaLight> vals,
                           std::span<const glm::vec3> entryIrradiance, std::span<glm::vec3> exitIrradiance) {
    const std::size_t exits = data.exitCount(), D = std::size_t(data.basisVectors), mapSize = 3 * exits;
    LIGHTSKIN_ASSERT(entryIrradiance.size() == data.entryCount() && exitIrradiance.size() == exits,
                     "lightskin::gi::prtExitIrradianceInto(): one value per entry and per exit point");
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t x = 0; x < std::ptrdiff_t(exits); ++x)
        exitIrradiance[std::size_t(x)] =
            data.exitObscurance[std::size_t(x)] *
            valIrradiance(vals, data.exitPositions[std::size_t(x)], data.exitNormals[std::size_t(x)]);
    // sec. 10: I[x] = sum_c (sum_{e in c} I_e) M_c[x] + sum_d (sum_{e in c} I_e w_d^e) B_d^c[x], per channel.
    for (std::uint32_t c = 0; c < data.clusterCount; ++c) {
        const float* maps = data.clusterMaps.data() + std::size_t(c) * (D + 1) * mapSize;
        for (std::size_t d = 0; d <= D; ++d) {
            glm::vec3 coefficient(0.0f);
            for (std::size_t e = 0; e < data.entryCount(); ++e)
                if (data.entryCluster[e] == c)
                    coefficient += entryIrradiance[e] * (d == 0 ? 1.0f : data.entryWeights[e * D + d - 1]);
            const float* map = maps + d * mapSize;
            for (std::size_t ch = 0; ch < 3; ++ch) {
                const float k = coefficient[int(ch)];
                if (k == 0.0f) continue;
                for (std::size_t x = 0; x < exits; ++x) exitIrradiance[x][int(ch)] += k * map[ch * exits + x];
            }
        }
    }
}

} // namespace lightskin::gi
