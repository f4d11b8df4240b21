#pragma once
// The SIMD kernels of CpuLightSkin (CpuGatherKernels.cpp, compiled once per instruction set by
// Google Highway and dispatched at run time). Data in structure-of-arrays form: one lane per
// receiver (sparse point), VALs / occluders broadcast one at a time, so each receiver's sums
// run over the VALs in list order whatever the thread or vector width.
#include "lightskin/src/LightSkinMath.h"

#include <lightskin/gi/common/VirtualAreaLight.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace lightskin::gi::cpu {

/// Receivers (and occluders) are padded to a multiple of this (the widest vector, AVX-512 floats),
/// so every instruction set processes whole vectors.
inline constexpr std::size_t kReceiverPadding = 16;
/// VALs per summation block (as gather_sum_block.glsl's kSumBlock): each block is summed from
/// zero, then added to the running sum. VAL arrays are padded to a multiple of it with zero-area
/// VALs, which add exactly +0 to every sum (finite terms times r^2 = 0 and flux = 0).
inline constexpr std::uint32_t kSumBlock = 16;
/// Sums per receiver, in the GL path's five-vec4 layout (LightSkinIllumination.cpp):
/// 0-3 (L'_d, sum r^2 w_d), 4-7 (sum (l-x) w_d, W_d), 8-11 (L'_s, sum r^2 w_s),
/// 12-15 (sum (l-x) w_s, W_s), 16-19 (sum (l-x)^2 w_d per axis, sum |l-x|^2 w_s); eps_l not included.
inline constexpr std::size_t kGatherSums = 20;

/// Valid VALs, SoA, padded to a multiple of kSumBlock.
struct ValArrays {
    std::vector<float> px, py, pz; ///< position, world metres
    /// minus the unit normal: the kernel's cos theta_j = max((-n) . t, 0) needs no negation
    /// (exact: negating is, and rounding is symmetric)
    std::vector<float> negNx, negNy, negNz;
    std::vector<float> r2;         ///< r^2 = area / pi, m^2
    std::vector<float> cr2;        ///< kCoincident r^2 (guard G1)
    std::vector<float> fr, fg, fb; ///< flux / pi (M w = (flux / pi) g, eq. 3-4)
    std::uint32_t count = 0;       ///< valid VALs
    std::uint32_t padded = 0;      ///< count rounded up to kSumBlock
    /// Per block of kSumBlock VALs: centre and half extent of the positions' bounding box
    /// (prepareGather()), for the exact skip of blocks behind a whole receiver group.
    std::vector<float> boxCx, boxCy, boxCz, boxHx, boxHy, boxHz;
    /// Per block: 2 |centre|_1 + |half extent|_1, the block's part of the skip test's rounding margin.
    std::vector<float> boxScale;
    void reserve(std::size_t capacity);
};

/// VAL `l` (area > 0) into slot n of `vals`, in the layout above: the one place that knows it, for
/// CpuLightSkin and the differential's gather alike.
inline void setVal(ValArrays& vals, std::uint32_t n, const VirtualAreaLight& l) {
    const float invPi = float(1.0 / refmath::kPi);
    const float r2 = l.area * invPi;
    vals.px[n] = l.position.x;
    vals.py[n] = l.position.y;
    vals.pz[n] = l.position.z;
    vals.negNx[n] = -l.normal.x;
    vals.negNy[n] = -l.normal.y;
    vals.negNz[n] = -l.normal.z;
    vals.r2[n] = r2;
    vals.cr2[n] = float(refmath::kCoincident) * r2;
    vals.fr[n] = l.flux.x * invPi;
    vals.fg[n] = l.flux.y * invPi;
    vals.fb[n] = l.flux.z * invPi;
}

/// Gather receivers, SoA, padded to kReceiverPadding (padding: finite dummies, results ignored).
struct ReceiverArrays {
    std::vector<float> px, py, pz, nx, ny, nz;
    std::vector<float> ex, ey, ez; ///< unit vector to the eye
    /// the eye direction mirrored about n, R = 2 (n . e) n - e: eq. 5's mirror cosine 2 (n.t)(n.e) - t.e = t . R
    std::vector<float> rx, ry, rz;
    std::vector<float> k, ck; ///< Phong exponent and c (k + 1)
    /// Receiver (column of the sums) in each slot: the identity as filled, the coherent order after
    /// prepareGather(). The kernels read slots and write the sums of receiver index[slot].
    std::vector<std::uint32_t> index;
    std::size_t padded = 0;
    void resize(std::size_t paddedCount);

private:
    friend void orderReceivers(ReceiverArrays&, std::size_t, std::span<const std::uint32_t>);
    std::vector<float> scratch_;
    std::vector<std::uint32_t> order_, grouped_, layout_;
    std::vector<std::uint64_t> keys_;
};

/// Once per frame, after the VALs and receivers [0, receiverCount) are filled in receiver order and
/// before gather(): the VAL blocks' bounding boxes, and the receivers reordered (index) so that each
/// group of kReceiverPadding shares its exponent and has nearby normals and positions. A group then
/// often lies wholly behind a VAL block (cos theta_i <= 0 for every pair), whose terms are all exactly
/// +0: the kernel skips it, and every sum stays the same bit for bit (x + 0 = x). The groups are then
/// laid out in bit-reversed order (CpuLightSkin lays them out in the order its threads take them). No
/// allocation.
void prepareGather(ValArrays& vals, ReceiverArrays& receivers, std::size_t receiverCount);
/// prepareGather()'s two parts: the bounding boxes of the VAL blocks [firstBlock, endBlock) (each block
/// independent: threads may split them), and the receivers' coherent order (serial: one sort).
/// `layout` (receiverCount / kReceiverPadding entries, else ignored): layout[pos] = the group of the
/// sorted order placed at slot group pos, a permutation; none: bitReversedLayout(). The layout moves
/// whole groups only, so no receiver's results depend on it.
void valBlockBoxes(ValArrays& vals, std::uint32_t firstBlock, std::uint32_t endBlock);
void orderReceivers(ReceiverArrays& receivers, std::size_t receiverCount, std::span<const std::uint32_t> layout);
/// The groups 0..layout.size()-1 in bit-reversed order: any contiguous range of slot groups then takes
/// about every (groups / range)-th group of the sorted order (sorted by exponent and normal, contiguous
/// halves differed by 1.3x in work); CpuLightSkin's order before it knows the groups' times.
void bitReversedLayout(std::span<std::uint32_t> layout);

struct GatherParameters {
    bool glossy = true;
    bool moments = true; ///< the occlusion stage needs the second moments
    /// Skip blocks wholly behind their receiver group (exact: prepareGather()); off only to check
    /// that or to measure it.
    bool skipHiddenBlocks = true;
};

/// Adds VALs [valBegin, valEnd) (multiples of kSumBlock) to the running sums of receivers
/// [receiverBegin, receiverEnd) (multiples of kReceiverPadding). sums[s * stride + i] is sum s of
/// receiver i; must hold the running sums of VALs [0, valBegin) (zero for valBegin = 0). Returns the
/// number of (VAL block, receiver) pairs skipped as wholly hidden.
std::uint64_t gather(const ValArrays& vals, std::uint32_t valBegin, std::uint32_t valEnd,
                     const ReceiverArrays& receivers, std::size_t receiverBegin, std::size_t receiverEnd,
                     const GatherParameters& parameters, float* sums, std::size_t stride);

/// Per receiver, its two occlusion targets (section 3.3) and frame, SoA, padded.
struct OcclusionReceivers {
    std::vector<float> px, py, pz, nx, ny, nz, tx, ty, tz, bx, by, bz;
    // diffuse (D) and glossy (S) target: centre (eq. 14), half side, 1/area (0 when area <=
    // kTinyArea: guard G7), distance |c - x|, 1 / max(radius, 1e-30)
    std::vector<float> dcx, dcy, dhalf, dinvArea, ddist, dinvRadius;
    std::vector<float> scx, scy, shalf, sinvArea, sdist, sinvRadius;
    std::size_t padded = 0;
    void resize(std::size_t paddedCount);
};

/// Occluder discs (every sparse point), SoA; count exact (not padded).
struct Occluders {
    std::vector<float> px, py, pz, nx, ny, nz, r2; ///< r2 = radius^2
    std::size_t count = 0;
    void resize(std::size_t n);
};

/// outD[i], outS[i] = sum over all occluders of the hidden fractions of receiver i's targets
/// (unclamped), for receivers [receiverBegin, receiverEnd) (multiples of kReceiverPadding). `skipHidden`:
/// skip an occluder below every receiver's horizon in a vector (its terms are all exactly +0, so no bit
/// changes; off only to check that). Returns the number of (occluder, receiver) pairs skipped.
std::uint64_t occlusion(const OcclusionReceivers& receivers, std::size_t receiverBegin, std::size_t receiverEnd,
                        const Occluders& occluders, bool glossy, float* outD, float* outS, bool skipHidden = true);

/// The gather's Phong lobe (guard G3 of lightskin_math.glsl): out[i] = cos^k for c = cosGamma[i],
/// k = exponent[i] >= 1; 0 where c <= 0 or k ln c < kMinLogPow. count: a multiple of
/// kReceiverPadding. For tests of its error bound (CpuGatherKernels.cpp, LobePow).
void lobePow(const float* cosGamma, const float* exponent, float* out, std::size_t count);

/// Name of the instruction set the dispatch chose (e.g. "AVX3", "AVX2", "SSE4").
std::string simdTargetName();
/// `steps` x 12 independent vector FMA chains at the dispatched width; returns the flops done
/// (2 per FMA lane), writes a lane of the result to *sink.
double fmaChains(std::uint64_t steps, float* sink);

} // namespace lightskin::gi::cpu
