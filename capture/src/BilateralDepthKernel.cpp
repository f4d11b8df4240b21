// BilateralDepthFilter's row kernel (BilateralDepthKernel.h). Highway compiles this file once per
// x86 instruction set (foreach_target.h re-includes it); HWY_DYNAMIC_DISPATCH picks the best at
// run time. Lane = output pixel of a row; taps broadcast one at a time, so every pixel sums its taps
// in the same order whatever the vector width.
//
// Per tap one exponential: the spatial and the range weight multiply, so their logarithms add,
// w = 2^(log2 s_k - (c dz)^2) with c^2 = log2(e) / (2 sigma_depth^2): one FMA for the exponent, then
// 2^y by Cephes' exp2f polynomial (core/Exp2-inl.h: relative error <= 2.9e-7 including its roundings).
#include "BilateralDepthKernel.h"

#include <lightskin/core/SimdTarget.h>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "BilateralDepthKernel.cpp"
#include <hwy/foreach_target.h> // re-includes this file once per target
#include <hwy/highway.h>
// after highway.h: per-target header, re-included for every target
#include <lightskin/core/Exp2-inl.h>

HWY_BEFORE_NAMESPACE();
namespace lightskin::capture::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using D = hn::ScalableTag<float>;
using V = hn::Vec<D>;

using lightskin::simd::HWY_NAMESPACE::Exp2; // core/Exp2-inl.h

void BilateralRowsImpl(const float* in, std::size_t inStride, std::size_t rows, std::size_t width,
                       const BilateralTaps& taps, float rangeScale, float* out, std::size_t outStride) {
    const D d;
    const std::size_t lanes = hn::Lanes(d);
    const V scale = hn::Set(d, rangeScale), lowest = hn::Set(d, -126.0f), one = hn::Set(d, 1.0f);
    // a centre at or beyond this is the missing-depth sentinel (the caller's is >= 1e18 m)
    const V missing = hn::Set(d, 1e17f);
    HWY_ALIGN float tail[kMaxBilateralLanes];
    for (std::size_t row = 0; row < rows; ++row) {
        const float* centreRow = in + row * inStride;
        float* outRow = out + row * outStride;
        for (std::size_t x = 0; x < width; x += lanes) {
            const float* c = centreRow + x;
            const V z0 = hn::LoadU(d, c);
            V sum = z0, weights = one; // the centre: weight 1
            for (std::size_t k = 0; k < taps.count; ++k) {
                const V z = hn::LoadU(d, c + taps.offsets[k]);
                const V cdz = hn::Mul(hn::Sub(z, z0), scale);
                const V y = hn::NegMulAdd(cdz, cdz, hn::Set(d, taps.log2Space[k]));
                // below 2^-126 the weight is < 1e-38 of the centre's: 0, as for the sentinel
                const V w = hn::IfThenElseZero(hn::Ge(y, lowest), Exp2(d, hn::Max(y, lowest)));
                sum = hn::MulAdd(w, z, sum);
                weights = hn::Add(weights, w);
            }
            const V result = hn::IfThenZeroElse(hn::Ge(z0, missing), hn::Div(sum, weights));
            if (x + lanes <= width) {
                hn::StoreU(result, d, outRow + x);
            } else {
                hn::Store(result, d, tail);
                for (std::size_t i = 0; x + i < width; ++i) outRow[x + i] = tail[i];
            }
        }
    }
}

const char* TargetNameImpl() { return hwy::TargetName(HWY_TARGET); }

} // namespace HWY_NAMESPACE
} // namespace lightskin::capture::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace lightskin::capture::detail {

HWY_EXPORT(BilateralRowsImpl);
HWY_EXPORT(TargetNameImpl);

void bilateralRows(const float* in, std::size_t inStride, std::size_t rows, std::size_t width,
                   const BilateralTaps& taps, float rangeScale, float* out, std::size_t outStride) {
    core::applySimdTargetCap();
    HWY_DYNAMIC_DISPATCH(BilateralRowsImpl)(in, inStride, rows, width, taps, rangeScale, out, outStride);
}

std::string bilateralTargetName() {
    core::applySimdTargetCap();
    return HWY_DYNAMIC_DISPATCH(TargetNameImpl)();
}

} // namespace lightskin::capture::detail
#endif
