// Multi-scale PRT's per-frame CPU part (sec. 10 of the paper): the VALs' irradiance at the entry and exit
// points and the compressed transfer. Compiled with -O3 and reassociation (gi/CMakeLists.txt) so that the
// VAL loops vectorise; formulas: gi/include/lightskin/gi/MultiscalePrt.h.
#include <lightskin/core/Error.h>
#include <lightskin/gi/MultiscalePrt.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <numbers>
#include <vector>

namespace lightskin::gi {

namespace {
constexpr float kPi = std::numbers::pi_v<float>;

// The valid VALs as structure-of-arrays, so that the receiver loop below vectorises (the 48-byte records would
// need gathers). Per thread, grown only: no allocation once a frame's VAL count has been seen.
struct ValArrays {
    std::vector<float> px, py, pz, nx, ny, nz, fr, fg, fb, area;
    std::size_t count = 0;
    void fill(std::span<const VirtualAreaLight> vals) {
        if (px.size() < vals.size())
            for (std::vector<float>* v : {&px, &py, &pz, &nx, &ny, &nz, &fr, &fg, &fb, &area}) v->resize(vals.size());
        count = 0;
        for (const VirtualAreaLight& val : vals) {
            if (!(val.area > 0.0f)) continue; // also skips NaN areas
            px[count] = val.position.x, py[count] = val.position.y, pz[count] = val.position.z;
            nx[count] = val.normal.x, ny[count] = val.normal.y, nz[count] = val.normal.z;
            fr[count] = val.flux.x, fg[count] = val.flux.y, fb[count] = val.flux.z;
            area[count] = val.area;
            ++count;
        }
    }
};

ValArrays& valArrays() {
    thread_local ValArrays arrays; // the calling thread's; filled before each parallel loop, read-only inside it
    return arrays;
}

// Unoccluded disc form factor of every VAL at p (LightSkin eq. 3): phi cos_j cos_p / (pi d^2 + A), cosines
// clamped at 0 (branch-free, so that it vectorises; a VAL at p itself has cos_p = 0 and adds 0).
glm::vec3 valIrradiance(const ValArrays& v, const glm::vec3& p, const glm::vec3& n) {
    float r = 0.0f, g = 0.0f, b = 0.0f;
    for (std::size_t j = 0; j < v.count; ++j) {
        const float dx = v.px[j] - p.x, dy = v.py[j] - p.y, dz = v.pz[j] - p.z;
        const float d2 = dx * dx + dy * dy + dz * dz;
        const float cosP = std::max(0.0f, n.x * dx + n.y * dy + n.z * dz);                // times |d|
        const float cosJ = std::max(0.0f, -(v.nx[j] * dx + v.ny[j] * dy + v.nz[j] * dz)); // times |d|
        const float w = cosP * cosJ / std::max(d2 * (kPi * d2 + v.area[j]), 1e-30f);
        r += v.fr[j] * w;
        g += v.fg[j] * w;
        b += v.fb[j] * w;
    }
    return {r, g, b};
}
} // namespace

void prtEntryIrradianceInto(const PrtData& data, std::span<const VirtualAreaLight> vals,
                            std::span<glm::vec3> entryIrradiance) {
    LIGHTSKIN_ASSERT(entryIrradiance.size() == data.entryCount(),
                     "lightskin::gi::prtEntryIrradianceInto(): one per entry");
    ValArrays& arrays = valArrays();
    arrays.fill(vals);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t e = 0; e < std::ptrdiff_t(data.entryCount()); ++e)
        entryIrradiance[std::size_t(e)] =
            data.entryObscurance[std::size_t(e)] *
            valIrradiance(arrays, data.entryPositions[std::size_t(e)], data.entryNormals[std::size_t(e)]);
}

void prtExitIrradianceInto(const PrtData& data, std::span<const VirtualAreaLight> vals,
                           std::span<const glm::vec3> entryIrradiance, std::span<glm::vec3> exitIrradiance) {
    const std::size_t exits = data.exitCount(), D = std::size_t(data.basisVectors), mapSize = 3 * exits;
    LIGHTSKIN_ASSERT(entryIrradiance.size() == data.entryCount() && exitIrradiance.size() == exits,
                     "lightskin::gi::prtExitIrradianceInto(): one value per entry and per exit point");
    ValArrays& arrays = valArrays();
    arrays.fill(vals);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t x = 0; x < std::ptrdiff_t(exits); ++x)
        exitIrradiance[std::size_t(x)] =
            data.exitObscurance[std::size_t(x)] *
            valIrradiance(arrays, data.exitPositions[std::size_t(x)], data.exitNormals[std::size_t(x)]);
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
