#pragma once
// Guard G12 of gi/lightskin/shaders/lightskin_math.glsl (near-field VALs as areas) for CpuLightSkin's flat
// gather. The SIMD kernels (CpuGatherKernels.cpp) evaluate eq. 3's point model for every receiver and
// VAL; this pass, run after them on the same receivers, adds for every pair within the near-field
// distance (|l - x| < 4 r) the difference between the area model and the point model, both from the
// double instance of lightskin_math.glsl. Kept out of the kernels: the pairs are few (at most ~16 VALs
// per receiver touching a surface) and the polygon integration is scalar work.
#include "CpuGatherKernels.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace lightskin::gi::cpu {

class NearFieldCorrection {
public:
    /// Indexes vals[0, count) in a hash grid of cells as wide as the largest near-field distance, so a
    /// receiver's near-field VALs lie in its 27 neighbouring cells. Reuses its storage (grows only).
    void index(const ValArrays& vals);
    /// Adds the correction to receivers [begin, end) of `sums` (kGatherSums layout, as cpu::gather()).
    /// Reads only; safe to call from several threads on disjoint receiver ranges.
    void apply(const ValArrays& vals, const ReceiverArrays& receivers, std::size_t begin, std::size_t end,
               const GatherParameters& parameters, float* sums, std::size_t stride) const;

private:
    double cell_ = 0.0;                ///< grid cell side, metres (0: no VAL indexed)
    std::uint64_t mask_ = 0;           ///< hash table size - 1 (a power of two)
    std::vector<std::uint32_t> start_; ///< per bucket, first entry in order_ (size mask_ + 2)
    std::vector<std::uint32_t> order_; ///< VAL indices sorted by bucket
    std::vector<std::uint64_t> bucketOf_;
};

} // namespace lightskin::gi::cpu
