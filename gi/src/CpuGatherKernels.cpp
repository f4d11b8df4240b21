// CpuLightSkin's SIMD kernels (CpuGatherKernels.h). Highway compiles this file once per x86
// instruction set (foreach_target.h re-includes it) and HWY_DYNAMIC_DISPATCH picks the best one
// the CPU supports at run time, so one binary runs everywhere and uses AVX-512 where it exists.
//
// The per-interaction math is gi/shaders/lightskin_math.glsl's (ls_gatherSample, guards G1-G3;
// ls_occluderAmount, G7) written with Highway operations, lane = receiver; the guard constants
// come from the double instance of that file (reference/LightSkinMath.h), so they exist once.
// Deviations, all within float rounding (stated bounds in tests/gi/gather/CpuLightSkinGLTest.cpp):
//  * 1/sqrt is the CPU's reciprocal-square-root estimate plus one Newton step (relative error
//    ~1e-7 after the step: 2^-14 estimate on AVX-512, 2^-12 on SSE/AVX, squared by the step);
//  * fused multiply-adds where the GL path rounds twice; M_j w_j = (flux / pi) g with flux / pi
//    precomputed per VAL; log and exp are Highway's (a few ulp).
// An invalid VAL never reaches these kernels (dropped when the arrays are built).
#include "CpuGatherKernels.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "CpuGatherKernels.cpp"
#include <hwy/foreach_target.h> // re-includes this file once per target
#include <hwy/highway.h>
// after highway.h: per-target header, re-included for every target
#include "reference/LightSkinMath.h"

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

HWY_INLINE V Dot(V ax, V ay, V az, V bx, V by, V bz) { return hn::MulAdd(az, bz, hn::MulAdd(ay, by, hn::Mul(ax, bx))); }

// The running sum of a receiver group: load, add the block sum, store (the block's grouping of
// gather_sum_block.glsl: block sums from zero, then running + block).
HWY_INLINE void AddBlock(D d, float* sum, V block) { hn::StoreU(hn::Add(hn::LoadU(d, sum), block), d, sum); }

template <bool kGlossy, bool kMoments>
HWY_NOINLINE void GatherGroup(const ValArrays& vals, std::uint32_t valBegin, std::uint32_t valEnd,
                              const ReceiverArrays& r, std::size_t i, float* sums, std::size_t stride) {
    namespace m = refmath;
    const D d;
    const V zero = hn::Zero(d);
    const V tiny = hn::Set(d, float(m::kTinyLength2));
    const V tinyCos = hn::Set(d, float(m::kTinyCos));
    const V minLogPow = hn::Set(d, float(m::kMinLogPow));
    const V one = hn::Set(d, 1.0f);
    const V x = hn::LoadU(d, &r.px[i]), y = hn::LoadU(d, &r.py[i]), z = hn::LoadU(d, &r.pz[i]);
    const V nx = hn::LoadU(d, &r.nx[i]), ny = hn::LoadU(d, &r.ny[i]), nz = hn::LoadU(d, &r.nz[i]);
    const V ex = hn::LoadU(d, &r.ex[i]), ey = hn::LoadU(d, &r.ey[i]), ez = hn::LoadU(d, &r.ez[i]);
    const V nde = hn::LoadU(d, &r.nde[i]), k = hn::LoadU(d, &r.k[i]), ck = hn::LoadU(d, &r.ck[i]);
    for (std::uint32_t first = valBegin; first < valEnd; first += kSumBlock) {
        V eR = zero, eG = zero, eB = zero, r2D = zero, oDx = zero, oDy = zero, oDz = zero, wDs = zero;
        V gR = zero, gG = zero, gB = zero, r2S = zero, oSx = zero, oSy = zero, oSz = zero, wSs = zero;
        V mx = zero, my = zero, mz = zero, mS = zero;
        for (std::uint32_t j = first; j < first + kSumBlock; ++j) {
            // eq. 3 geometry (ls_discTerms) with guards G1, G2
            const V ox = hn::Sub(hn::Set(d, vals.px[j]), x);
            const V oy = hn::Sub(hn::Set(d, vals.py[j]), y);
            const V oz = hn::Sub(hn::Set(d, vals.pz[j]), z);
            const V r2 = hn::Set(d, vals.r2[j]);
            const V d2 = Dot(ox, oy, oz, ox, oy, oz);
            const V invLength = InverseSqrt(d, hn::Max(hn::Add(d2, hn::Set(d, vals.cr2[j])), tiny));
            const V tx = hn::Mul(ox, invLength), ty = hn::Mul(oy, invLength), tz = hn::Mul(oz, invLength);
            const V ndl = Dot(nx, ny, nz, tx, ty, tz);
            const V cosI = hn::Max(ndl, zero);
            const V cosJ = hn::Max(
                hn::Neg(Dot(hn::Set(d, vals.nx[j]), hn::Set(d, vals.ny[j]), hn::Set(d, vals.nz[j]), tx, ty, tz)), zero);
            const V g = hn::Div(cosJ, hn::Max(hn::Add(r2, d2), tiny));
            const V w = hn::Mul(r2, g);      // eq. 3
            const V wD = hn::Mul(w, cosI);   // eq. 7 weight (eps_l folded later)
            const V gCos = hn::Mul(g, cosI); // E = (flux / pi) g cos(theta_i), eq. 4
            eR = hn::MulAdd(hn::Set(d, vals.fr[j]), gCos, eR);
            eG = hn::MulAdd(hn::Set(d, vals.fg[j]), gCos, eG);
            eB = hn::MulAdd(hn::Set(d, vals.fb[j]), gCos, eB);
            r2D = hn::MulAdd(r2, wD, r2D);
            oDx = hn::MulAdd(ox, wD, oDx);
            oDy = hn::MulAdd(oy, wD, oDy);
            oDz = hn::MulAdd(oz, wD, oDz);
            wDs = hn::Add(wDs, wD);
            if constexpr (kGlossy) {
                // eq. 5: cos(gamma) = mirror . e = 2 (n.l)(n.e) - l.e; cos^k with guard G3
                const V cosGamma = hn::MulSub(hn::Add(ndl, ndl), nde, Dot(tx, ty, tz, ex, ey, ez));
                const auto facing = hn::And(hn::Gt(cosGamma, zero), hn::Gt(cosI, zero));
                // A lane with lobe 0 adds exactly 0 to every glossy sum (finite terms times 0; a
                // sum is never -0), so skipping a VAL that no lane's lobe sees leaves the sums
                // bit-identical and saves the log and exp. Log's subnormal path is not needed:
                // its argument is >= kTinyCos = 1e-30, a normal float.
                if (!hn::AllFalse(d, facing)) {
                    const V e = hn::Mul(k, hn::impl::Log<D, V, false>(d, hn::Min(hn::Max(cosGamma, tinyCos), one)));
                    const auto lit = hn::And(facing, hn::Ge(e, minLogPow));
                    const V lobe = hn::IfThenElseZero(lit, hn::Exp(d, hn::Max(e, minLogPow)));
                    const V gLobe = hn::Mul(g, hn::Mul(ck, lobe));
                    gR = hn::MulAdd(hn::Set(d, vals.fr[j]), gLobe, gR);
                    gG = hn::MulAdd(hn::Set(d, vals.fg[j]), gLobe, gG);
                    gB = hn::MulAdd(hn::Set(d, vals.fb[j]), gLobe, gB);
                    const V wS = hn::Mul(w, lobe);
                    r2S = hn::MulAdd(r2, wS, r2S);
                    oSx = hn::MulAdd(ox, wS, oSx);
                    oSy = hn::MulAdd(oy, wS, oSy);
                    oSz = hn::MulAdd(oz, wS, oSz);
                    wSs = hn::Add(wSs, wS);
                    if constexpr (kMoments) mS = hn::MulAdd(d2, wS, mS);
                }
            }
            if constexpr (kMoments) {
                mx = hn::MulAdd(hn::Mul(ox, ox), wD, mx);
                my = hn::MulAdd(hn::Mul(oy, oy), wD, my);
                mz = hn::MulAdd(hn::Mul(oz, oz), wD, mz);
            }
        }
        float* s = sums + i;
        AddBlock(d, s + 0 * stride, eR);
        AddBlock(d, s + 1 * stride, eG);
        AddBlock(d, s + 2 * stride, eB);
        AddBlock(d, s + 3 * stride, r2D);
        AddBlock(d, s + 4 * stride, oDx);
        AddBlock(d, s + 5 * stride, oDy);
        AddBlock(d, s + 6 * stride, oDz);
        AddBlock(d, s + 7 * stride, wDs);
        if constexpr (kGlossy) {
            AddBlock(d, s + 8 * stride, gR);
            AddBlock(d, s + 9 * stride, gG);
            AddBlock(d, s + 10 * stride, gB);
            AddBlock(d, s + 11 * stride, r2S);
            AddBlock(d, s + 12 * stride, oSx);
            AddBlock(d, s + 13 * stride, oSy);
            AddBlock(d, s + 14 * stride, oSz);
            AddBlock(d, s + 15 * stride, wSs);
        }
        if constexpr (kMoments) {
            AddBlock(d, s + 16 * stride, mx);
            AddBlock(d, s + 17 * stride, my);
            AddBlock(d, s + 18 * stride, mz);
            if constexpr (kGlossy) AddBlock(d, s + 19 * stride, mS);
        }
    }
}

void GatherImpl(const ValArrays& vals, std::uint32_t valBegin, std::uint32_t valEnd, const ReceiverArrays& receivers,
                std::size_t receiverBegin, std::size_t receiverEnd, const GatherParameters& p, float* sums,
                std::size_t stride) {
    const std::size_t lanes = hn::Lanes(D());
    for (std::size_t i = receiverBegin; i < receiverEnd; i += lanes) {
        if (p.glossy && p.moments)
            GatherGroup<true, true>(vals, valBegin, valEnd, receivers, i, sums, stride);
        else if (p.glossy)
            GatherGroup<true, false>(vals, valBegin, valEnd, receivers, i, sums, stride);
        else if (p.moments)
            GatherGroup<false, true>(vals, valBegin, valEnd, receivers, i, sums, stride);
        else
            GatherGroup<false, false>(vals, valBegin, valEnd, receivers, i, sums, stride);
    }
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
HWY_NOINLINE void OcclusionGroup(const OcclusionReceivers& r, std::size_t i, const Occluders& o, float* outD,
                                 float* outS) {
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
    for (std::size_t j = 0; j < o.count; ++j) {
        const V vx = hn::Sub(hn::Set(d, o.px[j]), x), vy = hn::Sub(hn::Set(d, o.py[j]), y),
                vz = hn::Sub(hn::Set(d, o.pz[j]), z);
        const V d2 = Dot(vx, vy, vz, vx, vy, vz);
        const V inv = InverseSqrt(d, hn::Max(d2, tiny));
        const V ux = hn::Mul(vx, inv), uy = hn::Mul(vy, inv), uz = hn::Mul(vz, inv);
        const V cosI = Dot(nx, ny, nz, ux, uy, uz);
        const auto counts = hn::And(hn::Gt(d2, tiny), hn::Gt(cosI, zero)); // not the point itself, above the horizon
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
}

void OcclusionImpl(const OcclusionReceivers& receivers, std::size_t receiverBegin, std::size_t receiverEnd,
                   const Occluders& occluders, bool glossy, float* outD, float* outS) {
    const std::size_t lanes = hn::Lanes(D());
    for (std::size_t i = receiverBegin; i < receiverEnd; i += lanes) {
        if (glossy)
            OcclusionGroup<true>(receivers, i, occluders, outD, outS);
        else
            OcclusionGroup<false>(receivers, i, occluders, outD, outS);
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
HWY_EXPORT(FmaChainsImpl);

void ValArrays::reserve(std::size_t capacity) {
    for (auto* v : {&px, &py, &pz, &nx, &ny, &nz, &r2, &cr2, &fr, &fg, &fb}) v->resize(capacity);
}

void ReceiverArrays::resize(std::size_t paddedCount) {
    padded = paddedCount;
    for (auto* v : {&px, &py, &pz, &nx, &ny, &ex, &ey, &ez, &nde, &k, &ck}) v->assign(paddedCount, 0.0f);
    nz.assign(paddedCount, 1.0f);
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

void gather(const ValArrays& vals, std::uint32_t valBegin, std::uint32_t valEnd, const ReceiverArrays& receivers,
            std::size_t receiverBegin, std::size_t receiverEnd, const GatherParameters& parameters, float* sums,
            std::size_t stride) {
    HWY_DYNAMIC_DISPATCH(GatherImpl)
    (vals, valBegin, valEnd, receivers, receiverBegin, receiverEnd, parameters, sums, stride);
}

void occlusion(const OcclusionReceivers& receivers, std::size_t receiverBegin, std::size_t receiverEnd,
               const Occluders& occluders, bool glossy, float* outD, float* outS) {
    HWY_DYNAMIC_DISPATCH(OcclusionImpl)(receivers, receiverBegin, receiverEnd, occluders, glossy, outD, outS);
}

std::string simdTargetName() { return HWY_DYNAMIC_DISPATCH(TargetNameImpl)(); }

double fmaChains(std::uint64_t steps, float* sink) { return HWY_DYNAMIC_DISPATCH(FmaChainsImpl)(steps, sink); }

std::vector<std::string> simdTargetNames() {
    std::vector<std::string> names;
    for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) names.emplace_back(hwy::TargetName(target));
    return names;
}

bool restrictSimdTarget(const std::string& name) {
    if (name.empty()) {
        hwy::SetSupportedTargetsForTest(0);
        return true;
    }
    hwy::SetSupportedTargetsForTest(0);
    for (const std::int64_t target : hwy::SupportedAndGeneratedTargets())
        if (name == hwy::TargetName(target)) {
            hwy::SetSupportedTargetsForTest(target);
            return true;
        }
    return false;
}

} // namespace lightskin::gi::cpu
#endif
