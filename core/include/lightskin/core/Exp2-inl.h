// 2^y for float vectors, shared by the SIMD kernels of gi (the Phong lobe) and capture (the bilateral
// filter's weights). A Highway per-target header: include it after <hwy/highway.h> in a file that
// foreach_target.h re-includes, as Highway's own *-inl.h headers are.
//
// Cephes' exp2f polynomial: relative error <= 2.9e-7 including its roundings, for y in [-126, 0]
// (callers clamp).
#if defined(LIGHTSKIN_CORE_EXP2_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef LIGHTSKIN_CORE_EXP2_INL_H_
#undef LIGHTSKIN_CORE_EXP2_INL_H_
#else
#define LIGHTSKIN_CORE_EXP2_INL_H_
#endif

#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace lightskin::simd {
namespace HWY_NAMESPACE {

// n = nearest integer, f = y - n in [-1/2, 1/2] (exact), 2^f = 1 + f Q(f), 2^n added to the exponent
// bits (2^n >= 2^-126: a normal float).
template <class D>
HWY_INLINE hwy::HWY_NAMESPACE::Vec<D> Exp2(D d, hwy::HWY_NAMESPACE::Vec<D> y) {
    namespace hn = hwy::HWY_NAMESPACE;
    const hn::RebindToSigned<D> di;
    const auto n = hn::NearestInt(y);
    const auto f = hn::Sub(y, hn::ConvertTo(d, n));
    auto q = hn::Set(d, 1.535336188319500e-4f);
    q = hn::MulAdd(q, f, hn::Set(d, 1.339887440266574e-3f));
    q = hn::MulAdd(q, f, hn::Set(d, 9.618437357674640e-3f));
    q = hn::MulAdd(q, f, hn::Set(d, 5.550332471162809e-2f));
    q = hn::MulAdd(q, f, hn::Set(d, 2.402264791363012e-1f));
    q = hn::MulAdd(q, f, hn::Set(d, 6.931472028550421e-1f));
    const auto p = hn::MulAdd(q, f, hn::Set(d, 1.0f)); // 2^f in [0.70, 1.42]
    return hn::BitCast(d, hn::Add(hn::BitCast(di, p), hn::ShiftLeft<23>(n)));
}

} // namespace HWY_NAMESPACE
} // namespace lightskin::simd
HWY_AFTER_NAMESPACE();

#endif // LIGHTSKIN_CORE_EXP2_INL_H_
