// Multi-scale PRT's per-frame CPU part (sec. 10 of the paper): the VALs' irradiance at the entry and exit
// points and the compressed transfer. Compiled with -O3 and reassociation (gi/CMakeLists.txt) so that the
// VAL loops vectorise; formulas: gi/prt/include/lightskin/gi/prt/MultiscalePrt.h.
#include <lightskin/core/Error.h>
#include <lightskin/gi/prt/MultiscalePrt.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <limits>
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

// The irradiance vectors of the VALs above p's tangent plane, one per channel: V_c = sum_j phi_j,c cos_j d_j /
// (|d_j| (pi d_j^2 + A_j)) over the VALs with n . d_j > 0, so that E_c(p, n) = n . V_c exactly, and a nearby
// exit with another normal n' gets max(0, n' . V_c) (first order in the normal; exact while the VALs above
// both tangent planes are the same).
void valIrradianceVectors(const ValArrays& v, const glm::vec3& p, const glm::vec3& n, glm::vec3* out) {
    float rx = 0.0f, ry = 0.0f, rz = 0.0f, gx = 0.0f, gy = 0.0f, gz = 0.0f, bx = 0.0f, by = 0.0f, bz = 0.0f;
    for (std::size_t j = 0; j < v.count; ++j) {
        const float dx = v.px[j] - p.x, dy = v.py[j] - p.y, dz = v.pz[j] - p.z;
        const float d2 = dx * dx + dy * dy + dz * dz;
        const float above = n.x * dx + n.y * dy + n.z * dz > 0.0f ? 1.0f : 0.0f;
        const float cosJ = std::max(0.0f, -(v.nx[j] * dx + v.ny[j] * dy + v.nz[j] * dz)); // times |d|
        const float w = above * cosJ / std::max(d2 * (kPi * d2 + v.area[j]), 1e-30f);
        const float wr = v.fr[j] * w, wg = v.fg[j] * w, wb = v.fb[j] * w;
        rx += wr * dx, ry += wr * dy, rz += wr * dz;
        gx += wg * dx, gy += wg * dy, gz += wg * dz;
        bx += wb * dx, by += wb * dy, bz += wb * dz;
    }
    out[0] = {rx, ry, rz};
    out[1] = {gx, gy, gz};
    out[2] = {bx, by, bz};
}

glm::vec3 irradianceFromVectors(const glm::vec3* vectors, const glm::vec3& n) {
    return {std::max(0.0f, glm::dot(n, vectors[0])), std::max(0.0f, glm::dot(n, vectors[1])),
            std::max(0.0f, glm::dot(n, vectors[2]))};
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

namespace {
// sec. 10: I[x] += sum_c (sum_{e in c} I_e) M_c[x] + sum_d (sum_{e in c} I_e w_d^e) B_d^c[x], per channel.
void addTransfer(const PrtData& data, std::span<const glm::vec3> entryIrradiance, std::span<glm::vec3> exitIrradiance) {
    const std::size_t exits = data.exitCount(), D = std::size_t(data.basisVectors), mapSize = 3 * exits;
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

// The farthest-point and neighbour searches' metric, as the entry clusters' (PrtPrecompute.cpp): position over
// the bounding diagonal and half the normal, so that the two sides of a thin part are far apart.
float featureDistance2(const PrtData& data, std::size_t a, std::size_t b, float inverseDiagonal) {
    const glm::vec3 dp = (data.exitPositions[a] - data.exitPositions[b]) * inverseDiagonal;
    const glm::vec3 dn = 0.5f * (data.exitNormals[a] - data.exitNormals[b]);
    return glm::dot(dp, dp) + glm::dot(dn, dn);
}
} // namespace

void prtExitIrradianceInto(const PrtData& data, std::span<const VirtualAreaLight> vals,
                           std::span<const glm::vec3> entryIrradiance, std::span<glm::vec3> exitIrradiance) {
    const std::size_t exits = data.exitCount();
    LIGHTSKIN_ASSERT(entryIrradiance.size() == data.entryCount() && exitIrradiance.size() == exits,
                     "lightskin::gi::prtExitIrradianceInto(): one value per entry and per exit point");
    ValArrays& arrays = valArrays();
    arrays.fill(vals);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t x = 0; x < std::ptrdiff_t(exits); ++x)
        exitIrradiance[std::size_t(x)] =
            data.exitObscurance[std::size_t(x)] *
            valIrradiance(arrays, data.exitPositions[std::size_t(x)], data.exitNormals[std::size_t(x)]);
    addTransfer(data, entryIrradiance, exitIrradiance);
}

PrtGatherPlan planPrtGather(const PrtData& data, int gatherPoints, int neighbours) {
    LIGHTSKIN_ASSERT(gatherPoints >= 0 && neighbours >= 1 && neighbours <= 16,
                     "lightskin::gi::planPrtGather(): gatherPoints >= 0, neighbours in 1..16");
    PrtGatherPlan plan;
    const std::size_t exits = data.exitCount();
    if (gatherPoints == 0 || std::size_t(gatherPoints) >= exits) {
        plan.points.resize(exits);
        for (std::size_t x = 0; x < exits; ++x) plan.points[x] = std::uint32_t(x);
        return plan;
    }
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (const glm::vec3& p : data.exitPositions) lo = glm::min(lo, p), hi = glm::max(hi, p);
    const float diagonal = glm::length(hi - lo), inverseDiagonal = diagonal > 0.0f ? 1.0f / diagonal : 1.0f;

    // Farthest-point sampling: each new gather point is the exit farthest from all chosen ones, which spreads
    // them evenly over the surfaces whatever the tessellation (a dense part gets no more than a sparse one).
    constexpr std::int32_t kNone = -1;
    std::vector<std::int32_t> pointOf(exits, kNone);
    std::vector<float> nearest(exits, std::numeric_limits<float>::max());
    const auto add = [&](std::size_t x) {
        pointOf[x] = std::int32_t(plan.points.size());
        plan.points.push_back(std::uint32_t(x));
        for (std::size_t y = 0; y < exits; ++y)
            nearest[y] = std::min(nearest[y], featureDistance2(data, x, y, inverseDiagonal));
    };
    const std::size_t instances = data.exitOffsets.empty() ? 0 : data.exitOffsets.size() - 1;
    for (std::size_t m = 0; m < instances; ++m) // every instance at least one (neighbours never cross instances)
        if (data.exitOffsets[m] < data.exitOffsets[m + 1]) add(data.exitOffsets[m]);
    while (plan.points.size() < std::size_t(gatherPoints)) {
        const std::size_t far = std::size_t(std::max_element(nearest.begin(), nearest.end()) - nearest.begin());
        if (!(nearest[far] > 0.0f)) break; // every remaining exit coincides with a gather point
        add(far);
    }
    std::vector<std::uint32_t> instanceOf(exits, 0);
    for (std::size_t m = 0; m < instances; ++m)
        for (std::uint32_t x = data.exitOffsets[m]; x < data.exitOffsets[m + 1]; ++x) instanceOf[x] = std::uint32_t(m);
    std::vector<std::vector<std::uint32_t>> pointsOfInstance(instances);
    for (std::size_t g = 0; g < plan.points.size(); ++g)
        pointsOfInstance[instanceOf[plan.points[g]]].push_back(std::uint32_t(g));

    // k nearest gather points by position, same instance, normals within 30 degrees: irradiance changes with the
    // normal as fast as with the position, and across a crease or an instance it is another function.
    const std::size_t k = std::size_t(neighbours);
    constexpr float kCosMaxAngle = 0.8660254f; // cos 30 degrees
    plan.neighbours = neighbours;
    plan.slot.assign(exits * k, 0);
    plan.weight.assign(exits * k, 0.0f);
    std::vector<char> alone(exits, 0);
    const float tiny = 1e-12f * diagonal * diagonal; // keeps 1 / d^2 finite; d = 0 only for the point itself
#pragma omp parallel for schedule(dynamic, 64)
    for (std::ptrdiff_t xi = 0; xi < std::ptrdiff_t(exits); ++xi) {
        const std::size_t x = std::size_t(xi);
        if (pointOf[x] != kNone) {
            plan.slot[x * k] = std::uint32_t(pointOf[x]);
            plan.weight[x * k] = 1.0f;
            continue;
        }
        std::array<std::pair<float, std::uint32_t>, 16> best;
        std::size_t found = 0;
        for (const std::uint32_t g : pointsOfInstance[instanceOf[x]]) {
            const std::size_t p = plan.points[g];
            if (glm::dot(data.exitNormals[p], data.exitNormals[x]) < kCosMaxAngle) continue;
            const glm::vec3 d = data.exitPositions[p] - data.exitPositions[x];
            const float d2 = glm::dot(d, d);
            if (found == k && d2 >= best[k - 1].first) continue;
            std::size_t i = found < k ? found++ : k - 1; // insertion into the sorted k best
            for (; i > 0 && best[i - 1].first > d2; --i) best[i] = best[i - 1];
            best[i] = {d2, g};
        }
        if (found == 0) {
            alone[x] = 1;
            continue;
        }
        float sum = 0.0f;
        for (std::size_t i = 0; i < found; ++i) sum += 1.0f / (best[i].first + tiny);
        for (std::size_t i = 0; i < found; ++i) {
            plan.slot[x * k + i] = best[i].second;
            plan.weight[x * k + i] = 1.0f / (best[i].first + tiny) / sum;
        }
    }
    for (std::size_t x = 0; x < exits; ++x) // no gather point like it nearby: it is gathered itself
        if (alone[x]) {
            plan.slot[x * k] = std::uint32_t(plan.points.size());
            plan.weight[x * k] = 1.0f;
            plan.points.push_back(std::uint32_t(x));
        }
    return plan;
}

void prtExitIrradianceInto(const PrtData& data, const PrtGatherPlan& plan, std::span<const VirtualAreaLight> vals,
                           std::span<const glm::vec3> entryIrradiance, std::span<glm::vec3> gathered,
                           std::span<glm::vec3> exitIrradiance) {
    const std::size_t exits = data.exitCount(), k = std::size_t(plan.neighbours);
    LIGHTSKIN_ASSERT(entryIrradiance.size() == data.entryCount() && exitIrradiance.size() == exits &&
                         gathered.size() == 3 * plan.points.size() && (plan.exact() || plan.slot.size() == exits * k),
                     "lightskin::gi::prtExitIrradianceInto(): one value per entry, exit and gather point of the plan");
    ValArrays& arrays = valArrays();
    arrays.fill(vals);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t g = 0; g < std::ptrdiff_t(plan.points.size()); ++g) {
        const std::size_t x = plan.points[std::size_t(g)];
        valIrradianceVectors(arrays, data.exitPositions[x], data.exitNormals[x], &gathered[3 * std::size_t(g)]);
    }
    if (plan.exact()) {
        for (std::size_t g = 0; g < plan.points.size(); ++g) {
            const std::size_t x = plan.points[g];
            exitIrradiance[x] = data.exitObscurance[x] * irradianceFromVectors(&gathered[3 * g], data.exitNormals[x]);
        }
    } else {
#pragma omp parallel for schedule(static)
        for (std::ptrdiff_t xi = 0; xi < std::ptrdiff_t(exits); ++xi) {
            const std::size_t x = std::size_t(xi);
            glm::vec3 sum(0.0f);
            for (std::size_t i = 0; i < k; ++i)
                sum += plan.weight[x * k + i] *
                       irradianceFromVectors(&gathered[3 * std::size_t(plan.slot[x * k + i])], data.exitNormals[x]);
            exitIrradiance[x] = data.exitObscurance[x] * sum; // obscurance per exit: it is not smooth
        }
    }
    addTransfer(data, entryIrradiance, exitIrradiance);
}

} // namespace lightskin::gi
