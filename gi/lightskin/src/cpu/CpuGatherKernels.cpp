// CpuLightSkin's SIMD kernels (CpuGatherKernels.h). Highway compiles this file once per x86
// instruction set (foreach_target.h re-includes it) and HWY_DYNAMIC_DISPATCH picks the best one
// the CPU supports at run time, so one binary runs everywhere and uses AVX-512 where it exists.
//
// The per-interaction math is gi/lightskin/shaders/lightskin_math.glsl's (ls_gatherSample, guards G1-G3;
// ls_occluderAmount, G7) written with Highway operations, lane = receiver; the guard constants
// come from the double instance of that file (reference/LightSkinMath.h), so they exist once.
// Deviations, all within float rounding (stated bounds in tests/gi/lightskin/CpuLightSkinGLTest.cpp):
//  * 1/sqrt is the CPU's reciprocal-square-root estimate plus one Newton step (relative error
//    ~1e-7 after the step: 2^-14 estimate on AVX-512, 2^-12 on SSE/AVX, squared by the step);
//  * fused multiply-adds where the GL path rounds twice; M_j w_j = (flux / pi) g with flux / pi
//    precomputed per VAL; the lobe's c (k + 1) applied once per block of kSumBlock VALs;
//  * the products regrouped to save multiplies (GatherGroup): cos(gamma) = t . R with the mirrored
//    eye direction R per receiver, r^2 g cos theta_i as r^2 (g cos theta_i), the moments from
//    (l - x) w_d;
//  * cos^k by squaring where a receiver group shares an integer k <= 128, else by polynomial
//    log2 and exp2 (PowSquaring and LobePow below, error bounds there).
// An invalid VAL never reaches these kernels (dropped when the arrays are built).
#include "CpuGatherKernels.h"

#include <lightskin/core/SimdTarget.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "lightskin/src/cpu/CpuGatherKernels.cpp"
#include <hwy/foreach_target.h> // re-includes this file once per target
#include <hwy/highway.h>
// after highway.h: per-target header, re-included for every target
#include "lightskin/src/LightSkinMath.h"

#include <lightskin/core/Exp2-inl.h>

#include <hwy/contrib/math/math-inl.h>

HWY_BEFORE_NAMESPACE();
namespace lightskin::gi::cpu {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using D = hn::ScalableTag<float>;
using V = hn::Vec<D>;

// 1/sqrt(a) for a >= kTinyLength2: estimate + one Newton-Raphson step y (1.5 - 0.5 a y^2).
HWY_INLINE V InverseSqrt(D d, V a) {
    const V y = hn::ApproximateReciprocalSqrt(a);
    const V halfA = hn::Mul(a, hn::Set(d, 0.5f));
    return hn::Mul(y, hn::NegMulAdd(halfA, hn::Mul(y, y), hn::Set(d, 1.5f)));
}

// 2/sqrt(a), exactly twice InverseSqrt(a) bit for bit: y (3 - a y^2) is InverseSqrt's y (1.5 - (a/2) y^2)
// with both roundings scaled by 2 (a power of 2 commutes with rounding between the float limits, which
// these values, 1e-2..2e6, are far from). One multiply fewer (a/2); the gather folds the 2 into its
// receivers' halved normals and a doubled denominator (GatherGroup).
HWY_INLINE V TwiceInverseSqrt(D d, V a) {
    const V y = hn::ApproximateReciprocalSqrt(a);
    return hn::Mul(y, hn::NegMulAdd(a, hn::Mul(y, y), hn::Set(d, 3.0f)));
}

HWY_INLINE V Dot(V ax, V ay, V az, V bx, V by, V bz) { return hn::MulAdd(az, bz, hn::MulAdd(ay, by, hn::Mul(ax, bx))); }

// The running sum of a receiver group: load, add the block sum, store (the block's grouping of
// gather_sum_block.glsl: block sums from zero, then running + block).
HWY_INLINE void AddBlock(D d, float* sum, V block) { hn::StoreU(hn::Add(hn::LoadU(d, sum), block), d, sum); }

// cos^k = 2^(k log2 c) (guard G3) without a division or Highway's Log/Exp, for c in
// [kTinyCos, 1] and k >= 1 (callers clamp c; the lobe is 0 below kMinLogPow as in ls_pow):
//  * log2 c = e + log2(1 + x): e and m = 1 + x in [sqrt(1/2), sqrt(2)) from the float's bits
//    (x = m - 1 is exact, Sterbenz), ln(1 + x) = x - x^2/2 + x^3 P(x) with Cephes' logf
//    polynomial (minimax on that interval, 9 terms);
//  * 2^y for y in [kMinLogPow / ln 2, 0] = [-115.4, 0]: n = nearest integer, f = y - n in
//    [-1/2, 1/2] (exact), 2^f = 1 + f Q(f) with Cephes' exp2f polynomial (6 terms), 2^n added to
//    the exponent bits: 2^n >= 2^-116 is a normal float, so no subnormal path.
// Error: the computed y has relative error <= eps_y = 3.7e-7 (the polynomial's 7.6e-8 and 5
// roundings), i.e. an absolute error <= eps_y |y|, and 2^y then a relative error <= ln 2 eps_y |y| +
// eps_2, eps_2 = 2.9e-7 (exp2's polynomial and 2 roundings). ln 2 |y| = k |ln c| <= 80 where the lobe
// is not 0, and <= 7 where the lobe exceeds 1e-3 of its peak (error <= 2.9e-6 there, whatever k).
// Derivation and check on every SIMD target: tests/gi/lightskin/CpuLobePowTest.cpp (kEpsY, kEps2).
HWY_INLINE V Log2(D d, V c) {
    const hn::RebindToSigned<D> di;
    const auto bits = hn::BitCast(di, c);
    // e = floor(log2(c / sqrt(1/2))); m = c / 2^e in [sqrt(1/2), sqrt(2))
    const auto e = hn::ShiftRight<23>(hn::Sub(bits, hn::Set(di, 0x3F3504F3)));
    const V m = hn::BitCast(d, hn::Sub(bits, hn::ShiftLeft<23>(e)));
    const V x = hn::Sub(m, hn::Set(d, 1.0f));
    V p = hn::Set(d, 7.0376836292e-2f);
    p = hn::MulAdd(p, x, hn::Set(d, -1.1514610310e-1f));
    p = hn::MulAdd(p, x, hn::Set(d, 1.1676998740e-1f));
    p = hn::MulAdd(p, x, hn::Set(d, -1.2420140846e-1f));
    p = hn::MulAdd(p, x, hn::Set(d, 1.4249322787e-1f));
    p = hn::MulAdd(p, x, hn::Set(d, -1.6668057665e-1f));
    p = hn::MulAdd(p, x, hn::Set(d, 2.0000714765e-1f));
    p = hn::MulAdd(p, x, hn::Set(d, -2.4999993993e-1f));
    p = hn::MulAdd(p, x, hn::Set(d, 3.3333331174e-1f));
    const V x2 = hn::Mul(x, x);
    const V ln = hn::MulAdd(hn::Mul(x, x2), p, hn::NegMulAdd(x2, hn::Set(d, 0.5f), x)); // ln(1 + x)
    return hn::MulAdd(ln, hn::Set(d, 1.44269504088896341f), hn::ConvertTo(d, e));
}

using lightskin::simd::HWY_NAMESPACE::Exp2; // core/Exp2-inl.h

// The Phong lobe cos^k of ls_pow (G3) for lanes where `c` is the clamped-able mirror cosine:
// 0 where c <= 0 or k ln c < kMinLogPow, else 2^(k log2 c).
HWY_INLINE V LobePow(D d, V c, V k) {
    namespace m = refmath;
    const V minLog2Pow = hn::Set(d, float(m::kMinLogPow / 0.69314718055994530942));
    const V y = hn::Mul(k, Log2(d, hn::Min(hn::Max(c, hn::Set(d, float(m::kTinyCos))), hn::Set(d, 1.0f))));
    const auto lit = hn::And(hn::Gt(c, hn::Zero(d)), hn::Ge(y, minLog2Pow));
    return hn::IfThenElseZero(lit, Exp2(d, hn::Max(y, minLog2Pow)));
}

// cos^k for an integer k shared by every lane of a vector (one material per receiver group, as
// in practice): exponentiation by squaring, floor(log2 k) squarings and popcount(k) - 1
// products (k = 30: 7 multiplies against ~30 operations of LobePow). Error: squaring a value of
// relative error e gives 2e + u (u = 2^-24), a product of two adds theirs + u, so c^(2^j) carries
// (2^j - 1) u and c^k at most (k - 1) u to first order; for k <= kMaxSquaringExponent = 128 the
// higher-order terms add < 1e-5 of that: |lobe / exact - 1| <= 1.00001 (k - 1) u <= 7.6e-6.
// That is a quarter of the gather's own k-term for cos^k (2.4e-7 k: the float error of cos(gamma)
// amplified k times, LightSkinComparison.h) and checked in tests/gi/lightskin/CpuLobePowTest.cpp.
// Larger k takes LobePow: the error grows with k here, with k |ln c| there.
constexpr std::uint32_t kMaxSquaringExponent = 128;

// The exponent shared by all lanes of k if it is an integer in [1, kMaxSquaringExponent], else 0.
HWY_INLINE std::uint32_t UniformIntegerExponent(D d, V k) {
    const float k0 = hn::GetLane(k);
    if (!hn::AllTrue(d, hn::Eq(k, hn::Set(d, k0)))) return 0;
    if (!(k0 >= 1.0f && k0 <= float(kMaxSquaringExponent) && k0 == std::floor(k0))) return 0;
    return std::uint32_t(k0);
}

// G3 for one integer k as two cosines: lit where c >= litFrom, c clamped to >= floor. The cut-off
// k ln c < kMinLogPow <=> c < exp(kMinLogPow / k); rounding it to float moves it by < k u in k ln c,
// where either side is right (the lobe is ~e^-80 there). c >= the cut-off keeps every power c^j,
// j <= k, >= e^-80 (1 - 1e-5): normal floats, no slow subnormal arithmetic. For k = 1 the cut-off
// (e^-80) lies below G3's clamp kTinyCos (k ln kTinyCos = -69 > -80): every c > 0 is lit, at
// least kTinyCos.
struct SquaringLobe {
    std::uint32_t k = 0; ///< 0: not uniform, LobePow instead
    float litFrom = 0.0f, floor = 0.0f;
};
HWY_INLINE SquaringLobe SquaringLobeFor(std::uint32_t k) {
    if (k == 0) return {};
    const float cutoff = float(std::exp(refmath::kMinLogPow / double(k)));
    const float tiny = float(refmath::kTinyCos);
    return {k, cutoff > tiny ? cutoff : std::numeric_limits<float>::denorm_min(), std::max(cutoff, tiny)};
}

// c^k by squaring (see kMaxSquaringExponent) for c in [floor, 1] and k >= 1. The branches
// depend on k only, the same for a whole receiver group: predicted.
HWY_INLINE V PowSquaring(V c, std::uint32_t k) {
    V p = c;
    std::uint32_t e = k;
    for (; (e & 1u) == 0; e >>= 1) p = hn::Mul(p, p);
    V result = p;
    for (e >>= 1; e != 0; e >>= 1) {
        p = hn::Mul(p, p);
        if (e & 1u) result = hn::Mul(result, p);
    }
    return result;
}

// The lobe by squaring with G3's guards, given `lit` = c >= litFrom (callers test it first to
// skip VALs no lane sees).
HWY_INLINE V LobeSquaring(D d, V c, hn::Mask<D> lit, V floor, std::uint32_t k) {
    return hn::IfThenElseZero(lit, PowSquaring(hn::Min(hn::Max(c, floor), hn::Set(d, 1.0f)), k));
}

// Lanes per vector at most, over all targets this file is compiled for (scratch sizes).
constexpr std::size_t kMaxLanes = HWY_LANES(float);

template <bool kGlossy, bool kMoments>
HWY_NOINLINE std::uint64_t GatherGroup(const ValArrays& vals, std::uint32_t valBegin, std::uint32_t valEnd,
                                       const ReceiverArrays& r, std::size_t i, float* sums, std::size_t stride,
                                       bool skip) {
    namespace m = refmath;
    const D d;
    const std::size_t lanes = hn::Lanes(d);
    const V zero = hn::Zero(d);
    const V tiny = hn::Set(d, float(m::kTinyLength2));
    const V x = hn::LoadU(d, &r.px[i]), y = hn::LoadU(d, &r.py[i]), z = hn::LoadU(d, &r.pz[i]);
    // Per block of kSumBlock VALs, the glossy pass's inputs (mirror cosine, zeroed where the lobe
    // is 0 by facing; g; |l - x|^2): a second loop over the block then needs only the glossy sums in
    // registers. One loop with all 20 sums spilled them to the stack (perf annotate: 134 stack
    // accesses in the loop). The split changes no value; c (k + 1) now scales the block's glossy
    // radiance sums once instead of every term (rounding only).
    HWY_ALIGN float blockCos[kGlossy ? kSumBlock * kMaxLanes : 1];
    HWY_ALIGN float blockG[kGlossy ? kSumBlock * kMaxLanes : 1];
    HWY_ALIGN float blockD2[kGlossy && kMoments ? kSumBlock * kMaxLanes : 1];
    // The group's running sums live here while it runs over the VALs, written back at the end (the
    // same values). In place, its 20 rows sat `stride` floats apart, a multiple of 4 KB for 1024
    // receivers: all in one L1 set (8 ways), so every block's update missed L1 and its loads waited
    // on 4K-aliased stores (perf annotate: a quarter of the kernel's time in those updates).
    HWY_ALIGN float running[kGatherSums * kMaxLanes];
    const std::uint32_t* receiverOf = &r.index[i]; // slot -> receiver (column of the sums)
    for (std::size_t s = 0; s < kGatherSums; ++s)
        for (std::size_t lane = 0; lane < lanes; ++lane)
            running[s * lanes + lane] = sums[s * stride + receiverOf[lane]];
    const V k = hn::LoadU(d, &r.k[i]);
    const SquaringLobe squaring = SquaringLobeFor(kGlossy ? UniformIntegerExponent(d, k) : 0);
    const V litFrom = hn::Set(d, squaring.litFrom), floor = hn::Set(d, squaring.floor);
    // The skip test's per-group terms: n . x per lane, |n|, and the group's part of the margin's scale.
    const V gnx = hn::LoadU(d, &r.nx[i]), gny = hn::LoadU(d, &r.ny[i]), gnz = hn::LoadU(d, &r.nz[i]);
    const V nDotX = Dot(gnx, gny, gnz, x, y, z);
    const V absNx = hn::Abs(gnx), absNy = hn::Abs(gny), absNz = hn::Abs(gnz);
    const float groupScale =
        2.0f * hn::GetLane(hn::MaxOfLanes(d, hn::Add(hn::Add(hn::Abs(x), hn::Abs(y)), hn::Abs(z)))); // 2 max |x|_1
    // The receivers' halved normals and mirror directions (the pass below), made once per group
    const V half = hn::Set(d, 0.5f);
    HWY_ALIGN float halved[6 * kMaxLanes];
    hn::Store(hn::Mul(gnx, half), d, halved + 0 * lanes);
    hn::Store(hn::Mul(gny, half), d, halved + 1 * lanes);
    hn::Store(hn::Mul(gnz, half), d, halved + 2 * lanes);
    hn::Store(hn::Mul(hn::LoadU(d, &r.rx[i]), half), d, halved + 3 * lanes);
    hn::Store(hn::Mul(hn::LoadU(d, &r.ry[i]), half), d, halved + 4 * lanes);
    hn::Store(hn::Mul(hn::LoadU(d, &r.rz[i]), half), d, halved + 5 * lanes);
    std::uint64_t skipped = 0;
    for (std::uint32_t first = valBegin; first < valEnd; first += kSumBlock) {
        // The block behind every receiver of the group: max over its bounding box of n . (l - x) =
        // n . c + |n| . h - n . x < 0 with a margin of 1e-4 S, S = 2 |c|_1 + |h|_1 + 2 max |x|_1 >= every
        // |c|_1 + |h|_1 + |x|_1 of the group (|n_i| <= 1): the rounding of the box, of this bound, of
        // l - x and of the kernel's n . (l - x) is a few float epsilons (~1e-7) of that, so the kernel's
        // n . (l - x) is negative for all 256 pairs and cos theta_i = max(., 0) * 2/|l - x| exactly +0:
        // every term +0 (finite factors times +0), every block sum +0, and running + 0 = running.
        // Skipping it changes no bit of any sum (the glossy pass needs cos theta_i > 0 too).
        if (skip) {
            const std::size_t block = first / kSumBlock;
            const V bound = hn::Sub(hn::Add(Dot(gnx, gny, gnz, hn::Set(d, vals.boxCx[block]),
                                                hn::Set(d, vals.boxCy[block]), hn::Set(d, vals.boxCz[block])),
                                            Dot(absNx, absNy, absNz, hn::Set(d, vals.boxHx[block]),
                                                hn::Set(d, vals.boxHy[block]), hn::Set(d, vals.boxHz[block]))),
                                    nDotX);
            if (hn::AllTrue(d, hn::Lt(bound, hn::Set(d, -1e-4f * (vals.boxScale[block] + groupScale))))) {
                ++skipped;
                continue;
            }
        }
        V facingMax = zero; // the block's largest masked cos(gamma) per lane: > 0 where some VAL faces
        {
            // Shorter dependency chains and fewer multiplies than the GL path's order of operations (a
            // pass over a block ran at ~2/3 of the multiply pipes' rate, waiting on latency):
            //  * the dot products with l - x instead of the unit vector t, scaled by 1/|l - x| after, so
            //    they and g's division (cos theta_j = (-n_j).(l - x) / |l - x|: the division by
            //    r^2 + d^2 first) run beside the reciprocal square root instead of after it;
            //  * 2/|l - x| (TwiceInverseSqrt, one multiply fewer) with the 2 taken out exactly: the
            //    receivers' normals and mirror directions halved and g's denominator doubled by an add;
            //  * cos(gamma) = R . t with R = 2 (n.e) n - e per receiver (eq. 5's 2 (n.t)(n.e) - t.e
            //    regrouped: 3 operations instead of 4);
            //  * w = r^2 g not formed: wD = r^2 (g cos theta_i), wS = r^2 (g lobe);
            //  * the first and second moments from p = (l - x) wD: offset += p (an add), moment += (l - x) p.
            // All rounding only (the bounds in tests/gi/lightskin/CpuLightSkinGLTest.cpp hold unchanged).
            const V nx = hn::Load(d, halved + 0 * lanes), ny = hn::Load(d, halved + 1 * lanes),
                    nz = hn::Load(d, halved + 2 * lanes);
            const V tiny2 = hn::Add(tiny, tiny);
            const V mirrorX = hn::Load(d, halved + 3 * lanes), mirrorY = hn::Load(d, halved + 4 * lanes),
                    mirrorZ = hn::Load(d, halved + 5 * lanes);
            V eR = zero, eG = zero, eB = zero, r2D = zero, oDx = zero, oDy = zero, oDz = zero, wDs = zero;
            V mx = zero, my = zero, mz = zero;
            for (std::uint32_t j = first; j < first + kSumBlock; ++j) {
                // eq. 3 geometry (ls_discTerms) with guards G1, G2
                const V ox = hn::Sub(hn::Set(d, vals.px[j]), x);
                const V oy = hn::Sub(hn::Set(d, vals.py[j]), y);
                const V oz = hn::Sub(hn::Set(d, vals.pz[j]), z);
                const V r2 = hn::Set(d, vals.r2[j]);
                const V d2 = Dot(ox, oy, oz, ox, oy, oz);
                const V invLength2 = TwiceInverseSqrt(d, hn::Max(hn::Add(d2, hn::Set(d, vals.cr2[j])), tiny));
                const V b = hn::Add(r2, d2);
                // cos theta_j / max(r^2 + d^2, tiny) as max((-n_j).(l - x), 0) / (2 max(..)) times 2/|l - x|
                const V cosJOver = hn::Div(hn::Max(Dot(hn::Set(d, vals.negNx[j]), hn::Set(d, vals.negNy[j]),
                                                       hn::Set(d, vals.negNz[j]), ox, oy, oz),
                                                   zero),
                                           hn::Max(hn::Add(b, b), tiny2));
                const V g = hn::Mul(cosJOver, invLength2);
                const V cosI = hn::Mul(hn::Max(Dot(nx, ny, nz, ox, oy, oz), zero), invLength2); // (n/2).(l-x) 2/|l-x|
                const V gCos = hn::Mul(g, cosI); // E = (flux / pi) g cos(theta_i), eq. 4
                const V wD = hn::Mul(r2, gCos);  // eq. 7 weight r^2 g cos(theta_i) (eps_l folded later)
                eR = hn::MulAdd(hn::Set(d, vals.fr[j]), gCos, eR);
                eG = hn::MulAdd(hn::Set(d, vals.fg[j]), gCos, eG);
                eB = hn::MulAdd(hn::Set(d, vals.fb[j]), gCos, eB);
                r2D = hn::MulAdd(r2, wD, r2D);
                wDs = hn::Add(wDs, wD);
                if constexpr (kMoments) {
                    const V px = hn::Mul(ox, wD), py = hn::Mul(oy, wD), pz = hn::Mul(oz, wD);
                    oDx = hn::Add(oDx, px);
                    oDy = hn::Add(oDy, py);
                    oDz = hn::Add(oDz, pz);
                    mx = hn::MulAdd(ox, px, mx);
                    my = hn::MulAdd(oy, py, my);
                    mz = hn::MulAdd(oz, pz, mz);
                } else {
                    oDx = hn::MulAdd(ox, wD, oDx);
                    oDy = hn::MulAdd(oy, wD, oDy);
                    oDz = hn::MulAdd(oz, wD, oDz);
                }
                if constexpr (kGlossy) {
                    // eq. 5: cos(gamma) = mirror(t) . e = t . R
                    // zeroed where cos theta_i = 0; where cos(gamma) <= 0 it stays <= 0, which the
                    // glossy pass takes as unlit as it takes 0 (lit needs c >= litFrom > 0, or c > 0)
                    const V cosGamma = hn::IfThenElseZero(
                        hn::Gt(cosI, zero), hn::Mul(Dot(ox, oy, oz, mirrorX, mirrorY, mirrorZ), invLength2));
                    facingMax = hn::Max(facingMax, cosGamma);
                    const std::size_t at = (j - first) * lanes;
                    hn::Store(cosGamma, d, blockCos + at);
                    hn::Store(g, d, blockG + at);
                    if constexpr (kMoments) hn::Store(d2, d, blockD2 + at);
                }
            }
            float* s = running;
            AddBlock(d, s + 0 * lanes, eR);
            AddBlock(d, s + 1 * lanes, eG);
            AddBlock(d, s + 2 * lanes, eB);
            AddBlock(d, s + 3 * lanes, r2D);
            AddBlock(d, s + 4 * lanes, oDx);
            AddBlock(d, s + 5 * lanes, oDy);
            AddBlock(d, s + 6 * lanes, oDz);
            AddBlock(d, s + 7 * lanes, wDs);
            if constexpr (kMoments) {
                AddBlock(d, s + 16 * lanes, mx);
                AddBlock(d, s + 17 * lanes, my);
                AddBlock(d, s + 18 * lanes, mz);
            }
        }
        if constexpr (kGlossy) {
            // A lane with lobe 0 adds exactly +0 to every glossy sum (finite terms times 0; a sum
            // is never -0), so a block (or VAL) that no lane's lobe sees leaves the sums unchanged.
            V gR = zero, gG = zero, gB = zero, r2S = zero, oSx = zero, oSy = zero, oSz = zero, wSs = zero, mS = zero;
            if (!hn::AllFalse(d, hn::Gt(facingMax, zero))) {
                for (std::uint32_t j = first; j < first + kSumBlock; ++j) {
                    const std::size_t at = (j - first) * lanes;
                    const V c = hn::Load(d, blockCos + at);
                    V lobe;
                    if (squaring.k != 0) { // one integer k for the group: the common case
                        const auto lit = hn::Ge(c, litFrom);
                        if (hn::AllFalse(d, lit)) continue; // every lane's lobe 0 (G3): adds +0
                        lobe = LobeSquaring(d, c, lit, floor, squaring.k);
                    } else {
                        if (hn::AllFalse(d, hn::Gt(c, zero))) continue;
                        lobe = LobePow(d, c, k);
                    }
                    const V gLobe = hn::Mul(hn::Load(d, blockG + at), lobe); // c (k + 1) applied per block
                    gR = hn::MulAdd(hn::Set(d, vals.fr[j]), gLobe, gR);
                    gG = hn::MulAdd(hn::Set(d, vals.fg[j]), gLobe, gG);
                    gB = hn::MulAdd(hn::Set(d, vals.fb[j]), gLobe, gB);
                    const V r2 = hn::Set(d, vals.r2[j]);
                    const V wS = hn::Mul(r2, gLobe); // r^2 g lobe
                    const V ox = hn::Sub(hn::Set(d, vals.px[j]), x);
                    const V oy = hn::Sub(hn::Set(d, vals.py[j]), y);
                    const V oz = hn::Sub(hn::Set(d, vals.pz[j]), z);
                    r2S = hn::MulAdd(r2, wS, r2S);
                    oSx = hn::MulAdd(ox, wS, oSx);
                    oSy = hn::MulAdd(oy, wS, oSy);
                    oSz = hn::MulAdd(oz, wS, oSz);
                    wSs = hn::Add(wSs, wS);
                    if constexpr (kMoments) mS = hn::MulAdd(hn::Load(d, blockD2 + at), wS, mS); // |l - x|^2 of pass 1
                }
            }
            const V ck = hn::LoadU(d, &r.ck[i]);
            float* s = running;
            AddBlock(d, s + 8 * lanes, hn::Mul(ck, gR));
            AddBlock(d, s + 9 * lanes, hn::Mul(ck, gG));
            AddBlock(d, s + 10 * lanes, hn::Mul(ck, gB));
            AddBlock(d, s + 11 * lanes, r2S);
            AddBlock(d, s + 12 * lanes, oSx);
            AddBlock(d, s + 13 * lanes, oSy);
            AddBlock(d, s + 14 * lanes, oSz);
            AddBlock(d, s + 15 * lanes, wSs);
            if constexpr (kMoments) AddBlock(d, s + 19 * lanes, mS);
        }
    }
    for (std::size_t s = 0; s < kGatherSums; ++s)
        for (std::size_t lane = 0; lane < lanes; ++lane)
            sums[s * stride + receiverOf[lane]] = running[s * lanes + lane];
    return skipped;
}

std::uint64_t GatherImpl(const ValArrays& vals, std::uint32_t valBegin, std::uint32_t valEnd,
                         const ReceiverArrays& receivers, std::size_t receiverBegin, std::size_t receiverEnd,
                         const GatherParameters& p, float* sums, std::size_t stride) {
    const std::size_t lanes = hn::Lanes(D());
    const bool skip = p.skipHiddenBlocks;
    std::uint64_t skipped = 0;
    for (std::size_t i = receiverBegin; i < receiverEnd; i += lanes) {
        if (p.glossy && p.moments)
            skipped += GatherGroup<true, true>(vals, valBegin, valEnd, receivers, i, sums, stride, skip);
        else if (p.glossy)
            skipped += GatherGroup<true, false>(vals, valBegin, valEnd, receivers, i, sums, stride, skip);
        else if (p.moments)
            skipped += GatherGroup<false, true>(vals, valBegin, valEnd, receivers, i, sums, stride, skip);
        else
            skipped += GatherGroup<false, false>(vals, valBegin, valEnd, receivers, i, sums, stride, skip);
    }
    return skipped * lanes; // (VAL block, receiver) pairs, whatever the vector width
}

// Hidden fraction of one target (ls_occluderAmount after the shared per-occluder terms).
HWY_INLINE V TargetAmount(D d, V cx, V cy, V half, V invArea, V dist, V invRadius, V ucx, V ucy, V sideHalf, V dy) {
    const V zero = hn::Zero(d);
    const V ox = hn::Max(
        hn::Sub(hn::Min(hn::Add(cx, half), hn::Add(ucx, sideHalf)), hn::Max(hn::Sub(cx, half), hn::Sub(ucx, sideHalf))),
        zero);
    const V oy = hn::Max(
        hn::Sub(hn::Min(hn::Add(cy, half), hn::Add(ucy, sideHalf)), hn::Max(hn::Sub(cy, half), hn::Sub(ucy, sideHalf))),
        zero);
    const V depth = hn::Min(hn::Max(hn::Mul(hn::Sub(dist, dy), invRadius), zero), hn::Set(d, 1.0f));
    return hn::Mul(hn::Mul(hn::Mul(ox, oy), invArea), depth);
}

template <bool kGlossy>
HWY_NOINLINE std::uint64_t OcclusionGroup(const OcclusionReceivers& r, std::size_t i, const Occluders& o, float* outD,
                                          float* outS, bool skip) {
    namespace m = refmath;
    const D d;
    const V zero = hn::Zero(d);
    const V tiny = hn::Set(d, float(m::kTinyLength2));
    const V pi = hn::Set(d, float(m::kPi));
    const V x = hn::LoadU(d, &r.px[i]), y = hn::LoadU(d, &r.py[i]), z = hn::LoadU(d, &r.pz[i]);
    const V nx = hn::LoadU(d, &r.nx[i]), ny = hn::LoadU(d, &r.ny[i]), nz = hn::LoadU(d, &r.nz[i]);
    const V tx = hn::LoadU(d, &r.tx[i]), ty = hn::LoadU(d, &r.ty[i]), tz = hn::LoadU(d, &r.tz[i]);
    const V bx = hn::LoadU(d, &r.bx[i]), by = hn::LoadU(d, &r.by[i]), bz = hn::LoadU(d, &r.bz[i]);
    const V dcx = hn::LoadU(d, &r.dcx[i]), dcy = hn::LoadU(d, &r.dcy[i]), dhalf = hn::LoadU(d, &r.dhalf[i]);
    const V dinvArea = hn::LoadU(d, &r.dinvArea[i]), ddist = hn::LoadU(d, &r.ddist[i]),
            dinvRadius = hn::LoadU(d, &r.dinvRadius[i]);
    V sumD = zero, sumS = zero;
    std::uint64_t skipped = 0;
    for (std::size_t j = 0; j < o.count; ++j) {
        const V vx = hn::Sub(hn::Set(d, o.px[j]), x), vy = hn::Sub(hn::Set(d, o.py[j]), y),
                vz = hn::Sub(hn::Set(d, o.pz[j]), z);
        // Above the horizon: n . (y - x) > 0, tested before the normalisation (cos theta_i = n . (y - x) /
        // |y - x|: the same sign up to rounding where it is ~0, and the amount with it). No lane above it
        // (every receiver's tangent plane at or in front of the occluder: 2/3 of the pairs in bench-cpu's
        // scene, the groups being coherent): every term below would be IfThenElseZero's +0, and
        // sum + 0 = sum (a sum is never -0), so skipping it changes no bit; it skips before the
        // reciprocal square root and the normalisation, which these pairs paid before.
        const V nDotV = Dot(nx, ny, nz, vx, vy, vz);
        if (skip && hn::AllFalse(d, hn::Gt(nDotV, zero))) {
            ++skipped;
            continue;
        }
        const V d2 = Dot(vx, vy, vz, vx, vy, vz);
        const auto counts = hn::And(hn::Gt(d2, tiny), hn::Gt(nDotV, zero)); // not the point itself, above
        const V inv = InverseSqrt(d, hn::Max(d2, tiny));
        const V ux = hn::Mul(vx, inv), uy = hn::Mul(vy, inv), uz = hn::Mul(vz, inv);
        const V cosI = hn::Mul(nDotV, inv);
        const V r2 = hn::Set(d, o.r2[j]);
        const V cosO = hn::Abs(Dot(hn::Set(d, o.nx[j]), hn::Set(d, o.ny[j]), hn::Set(d, o.nz[j]), ux, uy, uz));
        const V area =
            hn::Mul(hn::Div(hn::Mul(hn::Mul(pi, cosO), r2), hn::Max(hn::Add(r2, d2), tiny)), cosI); // pi F_disk, eq. 3
        const V sideHalf = hn::Mul(hn::Sqrt(hn::Max(area, zero)), hn::Set(d, 0.5f));
        const V ucx = Dot(ux, uy, uz, tx, ty, tz), ucy = Dot(ux, uy, uz, bx, by, bz); // eq. 14
        const V dy = hn::Mul(d2, inv);                                                // |y - x|
        sumD = hn::Add(sumD, hn::IfThenElseZero(counts, TargetAmount(d, dcx, dcy, dhalf, dinvArea, ddist, dinvRadius,
                                                                     ucx, ucy, sideHalf, dy)));
        if constexpr (kGlossy) {
            const V a = TargetAmount(d, hn::LoadU(d, &r.scx[i]), hn::LoadU(d, &r.scy[i]), hn::LoadU(d, &r.shalf[i]),
                                     hn::LoadU(d, &r.sinvArea[i]), hn::LoadU(d, &r.sdist[i]),
                                     hn::LoadU(d, &r.sinvRadius[i]), ucx, ucy, sideHalf, dy);
            sumS = hn::Add(sumS, hn::IfThenElseZero(counts, a));
        }
    }
    hn::StoreU(sumD, d, outD + i);
    hn::StoreU(sumS, d, outS + i);
    return skipped;
}

std::uint64_t OcclusionImpl(const OcclusionReceivers& receivers, std::size_t receiverBegin, std::size_t receiverEnd,
                            const Occluders& occluders, bool glossy, float* outD, float* outS, bool skip) {
    std::uint64_t skipped = 0;
    const std::size_t lanes = hn::Lanes(D());
    for (std::size_t i = receiverBegin; i < receiverEnd; i += lanes) {
        if (glossy)
            skipped += OcclusionGroup<true>(receivers, i, occluders, outD, outS, skip);
        else
            skipped += OcclusionGroup<false>(receivers, i, occluders, outD, outS, skip);
    }
    return skipped * lanes;
}

// As the gather chooses per receiver group: squaring where a vector's lanes share an integer k.
void LobePowImpl(const float* c, const float* k, float* out, std::size_t count) {
    const D d;
    for (std::size_t i = 0; i < count; i += hn::Lanes(d)) {
        const V cv = hn::LoadU(d, c + i), kv = hn::LoadU(d, k + i);
        const SquaringLobe squaring = SquaringLobeFor(UniformIntegerExponent(d, kv));
        if (squaring.k != 0) {
            const V floor = hn::Set(d, squaring.floor);
            hn::StoreU(LobeSquaring(d, cv, hn::Ge(cv, hn::Set(d, squaring.litFrom)), floor, squaring.k), d, out + i);
        } else {
            hn::StoreU(LobePow(d, cv, kv), d, out + i);
        }
    }
}

const char* TargetNameImpl() { return hwy::TargetName(HWY_TARGET); }

// 12 independent FMA chains (enough to cover FMA latency x throughput on current x86 cores),
// as bench/PeakFlopsBenchmark.cpp, at the dispatched vector width. Returns the flops done.
double FmaChainsImpl(std::uint64_t steps, float* sink) {
    const D d;
    const V m = hn::Set(d, 0.999999f), c = hn::Set(d, 1e-7f);
    V a0 = hn::Set(d, 1.0f), a1 = hn::Set(d, 1.1f), a2 = hn::Set(d, 1.2f), a3 = hn::Set(d, 1.3f);
    V a4 = hn::Set(d, 1.4f), a5 = hn::Set(d, 1.5f), a6 = hn::Set(d, 1.6f), a7 = hn::Set(d, 1.7f);
    V a8 = hn::Set(d, 1.8f), a9 = hn::Set(d, 1.9f), a10 = hn::Set(d, 2.0f), a11 = hn::Set(d, 2.1f);
    for (std::uint64_t i = 0; i < steps; ++i) {
        a0 = hn::MulAdd(a0, m, c), a1 = hn::MulAdd(a1, m, c), a2 = hn::MulAdd(a2, m, c), a3 = hn::MulAdd(a3, m, c);
        a4 = hn::MulAdd(a4, m, c), a5 = hn::MulAdd(a5, m, c), a6 = hn::MulAdd(a6, m, c), a7 = hn::MulAdd(a7, m, c);
        a8 = hn::MulAdd(a8, m, c), a9 = hn::MulAdd(a9, m, c), a10 = hn::MulAdd(a10, m, c), a11 = hn::MulAdd(a11, m, c);
    }
    const V sum = hn::Add(hn::Add(hn::Add(hn::Add(a0, a1), hn::Add(a2, a3)), hn::Add(hn::Add(a4, a5), hn::Add(a6, a7))),
                          hn::Add(hn::Add(a8, a9), hn::Add(a10, a11)));
    *sink = hn::GetLane(sum); // keeps the chains alive
    return 2.0 * 12.0 * double(hn::Lanes(d)) * double(steps);
}

} // namespace HWY_NAMESPACE
} // namespace lightskin::gi::cpu
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace lightskin::gi::cpu {

HWY_EXPORT(GatherImpl);
HWY_EXPORT(OcclusionImpl);
HWY_EXPORT(TargetNameImpl);
HWY_EXPORT(LobePowImpl);
HWY_EXPORT(FmaChainsImpl);

void ValArrays::reserve(std::size_t capacity) {
    for (auto* v : {&px, &py, &pz, &negNx, &negNy, &negNz, &r2, &cr2, &fr, &fg, &fb}) v->resize(capacity);
    const std::size_t blocks = (capacity + kSumBlock - 1) / kSumBlock;
    for (auto* v : {&boxCx, &boxCy, &boxCz, &boxHx, &boxHy, &boxHz, &boxScale}) v->resize(blocks);
}

void ReceiverArrays::resize(std::size_t paddedCount) {
    padded = paddedCount;
    for (auto* v : {&px, &py, &pz, &nx, &ny, &ex, &ey, &ez, &rx, &ry, &rz, &k, &ck}) v->assign(paddedCount, 0.0f);
    nz.assign(paddedCount, 1.0f);
    index.resize(paddedCount);
    for (std::size_t i = 0; i < paddedCount; ++i) index[i] = std::uint32_t(i);
    scratch_.resize(paddedCount);
    order_.resize(paddedCount);
    grouped_.resize(paddedCount);
    keys_.resize(paddedCount);
    layout_.resize(paddedCount / kReceiverPadding);
}

namespace {

/// Sort key of a receiver: exponent (a group shares it: squaring), normal (6 cube faces x 4 x 4
/// cells), then position (Morton order, 8 bits per axis over the receivers' bounding box).
std::uint64_t coherenceKey(float k, float nx, float ny, float nz, const float unit[3]) {
    const float a[3] = {std::abs(nx), std::abs(ny), std::abs(nz)};
    const int axis = a[0] >= a[1] && a[0] >= a[2] ? 0 : (a[1] >= a[2] ? 1 : 2);
    const float n[3] = {nx, ny, nz};
    const float major = std::max(a[axis], 1e-30f);
    const auto cell = [&](int c) {
        const float t = (n[(axis + c) % 3] / major + 1.0f) * 2.0f; // [0, 4]
        return std::uint64_t(std::clamp(int(t), 0, 3));
    };
    const std::uint64_t bucket = std::uint64_t(axis * 2 + (n[axis] < 0.0f ? 1 : 0)) * 16 + cell(1) * 4 + cell(2);
    std::uint64_t morton = 0;
    for (int bit = 7; bit >= 0; --bit)
        for (int c = 0; c < 3; ++c) morton = (morton << 1) | ((std::uint64_t(unit[c]) >> bit) & 1u);
    return (std::uint64_t(std::bit_cast<std::uint32_t>(k)) << 31) | (bucket << 24) | morton;
}

} // namespace

void prepareGather(ValArrays& v, ReceiverArrays& r, std::size_t count) {
    valBlockBoxes(v, 0, v.padded / kSumBlock);
    orderReceivers(r, count, {});
}

void valBlockBoxes(ValArrays& v, std::uint32_t firstBlock, std::uint32_t endBlock) {
    for (std::uint32_t b = firstBlock; b < endBlock; ++b) {
        float lo[3] = {v.px[b * kSumBlock], v.py[b * kSumBlock], v.pz[b * kSumBlock]};
        float hi[3] = {lo[0], lo[1], lo[2]};
        for (std::uint32_t j = b * kSumBlock; j < (b + 1) * kSumBlock; ++j) {
            const float p[3] = {v.px[j], v.py[j], v.pz[j]};
            for (int c = 0; c < 3; ++c) lo[c] = std::min(lo[c], p[c]), hi[c] = std::max(hi[c], p[c]);
        }
        v.boxCx[b] = 0.5f * (lo[0] + hi[0]), v.boxHx[b] = 0.5f * (hi[0] - lo[0]);
        v.boxCy[b] = 0.5f * (lo[1] + hi[1]), v.boxHy[b] = 0.5f * (hi[1] - lo[1]);
        v.boxCz[b] = 0.5f * (lo[2] + hi[2]), v.boxHz[b] = 0.5f * (hi[2] - lo[2]);
        v.boxScale[b] = 2.0f * (std::abs(v.boxCx[b]) + std::abs(v.boxCy[b]) + std::abs(v.boxCz[b])) +
                        (v.boxHx[b] + v.boxHy[b] + v.boxHz[b]);
    }
}

void bitReversedLayout(std::span<std::uint32_t> layout) {
    const std::size_t full = layout.size();
    std::size_t bits = 0;
    while ((std::size_t(1) << bits) < full) ++bits;
    std::size_t at = 0;
    for (std::size_t i = 0; i < (std::size_t(1) << bits); ++i) {
        std::size_t g = 0;
        for (std::size_t b = 0; b < bits; ++b) g |= ((i >> b) & 1u) << (bits - 1 - b);
        if (g < full) layout[at++] = std::uint32_t(g);
    }
}

void orderReceivers(ReceiverArrays& r, std::size_t count, std::span<const std::uint32_t> layout) {
    for (std::size_t i = 0; i < r.padded; ++i) r.index[i] = std::uint32_t(i);
    if (count < 2) return;
    float lo[3] = {r.px[0], r.py[0], r.pz[0]}, hi[3] = {lo[0], lo[1], lo[2]};
    for (std::size_t i = 0; i < count; ++i) {
        const float p[3] = {r.px[i], r.py[i], r.pz[i]};
        for (int c = 0; c < 3; ++c) lo[c] = std::min(lo[c], p[c]), hi[c] = std::max(hi[c], p[c]);
    }
    for (std::size_t i = 0; i < count; ++i) {
        const float p[3] = {r.px[i], r.py[i], r.pz[i]};
        float unit[3];
        for (int c = 0; c < 3; ++c)
            unit[c] = hi[c] > lo[c] ? std::clamp((p[c] - lo[c]) / (hi[c] - lo[c]) * 255.0f, 0.0f, 255.0f) : 0.0f;
        if (!(std::isfinite(unit[0]) && std::isfinite(unit[1]) && std::isfinite(unit[2])))
            unit[0] = unit[1] = unit[2] = 0;
        r.keys_[i] = coherenceKey(r.k[i], r.nx[i], r.ny[i], r.nz[i], unit);
        r.order_[i] = std::uint32_t(i);
    }
    // ties by receiver index: one order whatever the sort's implementation
    std::sort(r.order_.begin(), r.order_.begin() + std::ptrdiff_t(count), [&](std::uint32_t a, std::uint32_t b) {
        return r.keys_[a] != r.keys_[b] ? r.keys_[a] < r.keys_[b] : a < b;
    });
    // Whole groups in the given layout or bit-reversed order (the partial last group stays last: the
    // padding slots follow it).
    const std::size_t full = count / kReceiverPadding;
    const bool given = layout.size() == full;
    if (!given) bitReversedLayout(std::span(r.layout_).first(full));
    std::size_t at = 0;
    for (std::size_t pos = 0; pos < full; ++pos) {
        const std::size_t g = given ? layout[pos] : r.layout_[pos];
        for (std::size_t lane = 0; lane < kReceiverPadding; ++lane)
            r.grouped_[at++] = r.order_[g * kReceiverPadding + lane];
    }
    for (std::size_t s = at; s < count; ++s) r.grouped_[s] = r.order_[s];
    std::copy_n(r.grouped_.begin(), count, r.order_.begin());
    for (auto* a : {&r.px, &r.py, &r.pz, &r.nx, &r.ny, &r.nz, &r.ex, &r.ey, &r.ez, &r.rx, &r.ry, &r.rz, &r.k, &r.ck}) {
        for (std::size_t s = 0; s < count; ++s) r.scratch_[s] = (*a)[r.order_[s]];
        std::copy_n(r.scratch_.begin(), count, a->begin());
    }
    for (std::size_t s = 0; s < count; ++s) r.index[s] = r.order_[s];
}

void OcclusionReceivers::resize(std::size_t paddedCount) {
    padded = paddedCount;
    for (auto* v :
         {&px,  &py,  &pz,    &nx,       &ny,    &nz,         &tx,  &ty,  &tz,    &bx,       &by,    &bz,
          &dcx, &dcy, &dhalf, &dinvArea, &ddist, &dinvRadius, &scx, &scy, &shalf, &sinvArea, &sdist, &sinvRadius})
        v->assign(paddedCount, 0.0f);
}

void Occluders::resize(std::size_t n) {
    count = n;
    for (auto* v : {&px, &py, &pz, &nx, &ny, &nz, &r2}) v->assign(n, 0.0f);
}

std::uint64_t gather(const ValArrays& vals, std::uint32_t valBegin, std::uint32_t valEnd,
                     const ReceiverArrays& receivers, std::size_t receiverBegin, std::size_t receiverEnd,
                     const GatherParameters& parameters, float* sums, std::size_t stride) {
    core::applySimdTargetCap(); // once per process; the CPU backend's first frame applies it
    return HWY_DYNAMIC_DISPATCH(GatherImpl)(vals, valBegin, valEnd, receivers, receiverBegin, receiverEnd, parameters,
                                            sums, stride);
}

std::uint64_t occlusion(const OcclusionReceivers& receivers, std::size_t receiverBegin, std::size_t receiverEnd,
                        const Occluders& occluders, bool glossy, float* outD, float* outS, bool skipHidden) {
    core::applySimdTargetCap();
    return HWY_DYNAMIC_DISPATCH(OcclusionImpl)(receivers, receiverBegin, receiverEnd, occluders, glossy, outD, outS,
                                               skipHidden);
}

void lobePow(const float* cosGamma, const float* exponent, float* out, std::size_t count) {
    core::applySimdTargetCap();
    HWY_DYNAMIC_DISPATCH(LobePowImpl)(cosGamma, exponent, out, count);
}

std::string simdTargetName() {
    core::applySimdTargetCap();
    return HWY_DYNAMIC_DISPATCH(TargetNameImpl)();
}

double fmaChains(std::uint64_t steps, float* sink) {
    core::applySimdTargetCap();
    return HWY_DYNAMIC_DISPATCH(FmaChainsImpl)(steps, sink);
}

} // namespace lightskin::gi::cpu
#endif
