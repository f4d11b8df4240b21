// Guard G12 for CpuLightSkin's flat gather: see CpuNearField.h.
#include "CpuNearField.h"

#include "lightskin/src/LightSkinMath.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>

namespace lightskin::gi::cpu {

namespace {

namespace m = refmath;

// Cell coordinates are clamped so that no float position (finite or not) overflows the int64 maths.
constexpr double kMaxCell = 1.0e9;

std::int64_t cellCoordinate(double p, double cell) {
    const double c = std::floor(p / cell);
    return std::int64_t(std::clamp(std::isnan(c) ? 0.0 : c, -kMaxCell, kMaxCell));
}

std::uint64_t hashCell(std::int64_t x, std::int64_t y, std::int64_t z, std::uint64_t mask) {
    const auto h = std::uint64_t(x) * 73856093ull ^ std::uint64_t(y) * 19349663ull ^ std::uint64_t(z) * 83492791ull;
    return (h ^ (h >> 29)) & mask;
}

} // namespace

void NearFieldCorrection::index(const ValArrays& vals) {
    double r2Max = 0.0;
    for (std::uint32_t j = 0; j < vals.count; ++j) r2Max = std::max(r2Max, double(vals.r2[j]));
    cell_ = std::sqrt(m::kNearFieldRatio2 * r2Max);
    if (!(cell_ > 0.0) || !std::isfinite(cell_)) {
        cell_ = 0.0;
        return;
    }
    std::uint64_t buckets = 1;
    while (buckets < vals.count) buckets *= 2;
    mask_ = buckets - 1;
    start_.assign(buckets + 1, 0u);
    bucketOf_.resize(std::max<std::size_t>(bucketOf_.size(), vals.count));
    order_.resize(std::max<std::size_t>(order_.size(), vals.count));
    for (std::uint32_t j = 0; j < vals.count; ++j) {
        bucketOf_[j] = hashCell(cellCoordinate(vals.px[j], cell_), cellCoordinate(vals.py[j], cell_),
                                cellCoordinate(vals.pz[j], cell_), mask_);
        ++start_[bucketOf_[j] + 1];
    }
    for (std::size_t b = 1; b < start_.size(); ++b) start_[b] += start_[b - 1];
    // counting sort; start_[b] walks to the next bucket's start, then is shifted back
    for (std::uint32_t j = 0; j < vals.count; ++j) order_[start_[bucketOf_[j]]++] = j;
    for (std::size_t b = start_.size() - 1; b > 0; --b) start_[b] = start_[b - 1];
    start_[0] = 0;
}

void NearFieldCorrection::apply(const ValArrays& vals, const ReceiverArrays& r, std::size_t begin, std::size_t end,
                                const GatherParameters& parameters, float* sums, std::size_t stride) const {
    if (cell_ == 0.0) return;
    for (std::size_t i = begin; i < end; ++i) {
        const glm::dvec3 x(r.px[i], r.py[i], r.pz[i]), n(r.nx[i], r.ny[i], r.nz[i]), toEye(r.ex[i], r.ey[i], r.ez[i]);
        const double k = double(r.k[i]), ck = double(r.ck[i]);
        // the 27 cells around x, each bucket once (cells may share a bucket)
        std::array<std::uint64_t, 27> buckets{};
        std::size_t count = 0;
        const std::int64_t cx = cellCoordinate(x.x, cell_), cy = cellCoordinate(x.y, cell_),
                           cz = cellCoordinate(x.z, cell_);
        for (std::int64_t dz = -1; dz <= 1; ++dz)
            for (std::int64_t dy = -1; dy <= 1; ++dy)
                for (std::int64_t dx = -1; dx <= 1; ++dx) {
                    const std::uint64_t b = hashCell(cx + dx, cy + dy, cz + dz, mask_);
                    if (std::find(buckets.begin(), buckets.begin() + std::ptrdiff_t(count), b) ==
                        buckets.begin() + std::ptrdiff_t(count))
                        buckets[count++] = b;
                }
        std::array<double, kGatherSums> delta{};
        bool any = false;
        for (std::size_t c = 0; c < count; ++c)
            for (std::uint32_t e = start_[buckets[c]]; e < start_[buckets[c] + 1]; ++e) {
                const std::uint32_t j = order_[e];
                const glm::dvec3 l(vals.px[j], vals.py[j], vals.pz[j]);
                const glm::dvec3 o = l - x;
                const double r2 = double(vals.r2[j]);
                if (!(glm::dot(o, o) < m::kNearFieldRatio2 * r2)) continue; // as ls_discTerms decides
                const glm::dvec3 nl(-vals.negNx[j], -vals.negNy[j], -vals.negNz[j]);
                const glm::dvec3 flux = glm::dvec3(vals.fr[j], vals.fg[j], vals.fb[j]) * m::kPi;
                const double area = m::kPi * r2;
                const m::GatherSample a = m::ls_gatherSample(x, n, l, nl, area, flux, toEye, k, ck, 0.0, true);
                const m::GatherSample p = m::ls_gatherSample(x, n, l, nl, area, flux, toEye, k, ck, 0.0, false);
                const auto add = [&](std::size_t s, double value) { delta[s] += value; };
                for (int c3 = 0; c3 < 3; ++c3) add(std::size_t(c3), a.irradiance[c3] - p.irradiance[c3]);
                add(3, r2 * (a.weightD - p.weightD));
                for (int c3 = 0; c3 < 3; ++c3) add(std::size_t(4 + c3), o[c3] * (a.weightD - p.weightD));
                add(7, a.weightD - p.weightD);
                if (parameters.glossy) {
                    for (int c3 = 0; c3 < 3; ++c3) add(std::size_t(8 + c3), a.glossy[c3] - p.glossy[c3]);
                    add(11, r2 * (a.weightS - p.weightS));
                    for (int c3 = 0; c3 < 3; ++c3) add(std::size_t(12 + c3), o[c3] * (a.weightS - p.weightS));
                    add(15, a.weightS - p.weightS);
                }
                if (parameters.moments) {
                    for (int c3 = 0; c3 < 3; ++c3) add(std::size_t(16 + c3), o[c3] * o[c3] * (a.weightD - p.weightD));
                    if (parameters.glossy) add(19, glm::dot(o, o) * (a.weightS - p.weightS));
                }
                any = true;
            }
        if (!any) continue;
        // slot i holds receiver r.index[i] (prepareGather reorders the slots, not the sums)
        for (std::size_t s = 0; s < kGatherSums; ++s) sums[s * stride + r.index[i]] += float(delta[s]);
    }
}

} // namespace lightskin::gi::cpu
