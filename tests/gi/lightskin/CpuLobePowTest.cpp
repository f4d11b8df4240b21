// The CPU backend's Phong lobe cos^k (polynomial log2 and exp2 in CpuGatherKernels.cpp) against the
// closed form exp(k ln c) in double with guard G3 of lightskin_math.glsl (c clamped to [1e-30, 1], 0
// where c <= 0 or k ln c < -80), on every SIMD target this CPU runs, over dense sweeps of c and the
// exponents from k = 1 to 1e4 (the extremes suite's range).
//
// Error bound (derived, not measured): the kernel computes y = k log2 c with relative error
// eps_y and 2^y with relative error eps_2, so |lobe / exact - 1| <= ln 2 eps_y |y| + eps_2 (to first
// order; eps_y |y| <= 5e-5 here, its square is negligible). With u = 2^-24:
//  * eps_y <= 7.6e-8 + 5u = 3.7e-7: Cephes' logf polynomial on [sqrt(1/2), sqrt(2)) has peak
//    relative error 7.6e-8; x = m - 1 is exact (Sterbenz); x^2, x^3, the final fused sum, the fused
//    log2(e) scaling and the product with k round once each (the Horner steps only touch the x^3
//    term, at most x^2 / 3 < 0.06 of the result, so their roundings stay below 0.1u);
//  * eps_2 <= 1.7e-7 + 2u = 2.9e-7: Cephes' exp2f polynomial on [-1/2, 1/2] (peak 1.7e-7); f = y - n
//    is exact; the last fused step rounds once, the earlier ones are scaled by |f| <= 1/2; adding n
//    to the exponent bits is exact (2^n >= 2^-116, normal).
// Near the cut-off (k ln c within eps_y 80 of -80) either side of the guard is right: the lobe is
// then <= e^-80 (1 + 1e-4) ~ 1.8e-35, the guard's own stated absolute error.
//
// Where all lanes of a vector share an integer k <= 128 (here: every integer exponent of the sweep
// up to 100) the kernels take exponentiation by squaring instead (PowSquaring): squaring a value
// of relative error e gives 2e + u, a product adds the factors' errors + u, so c^k carries at most
// (k - 1) u to first order, and (1 + u)^127 - 1 < 1.00001 x 127 u bounds the rest: |lobe / exact -
// 1| <= 1.00001 (k - 1) u (exact for k = 1: the lobe is c itself; 1e-12 covers the double
// closed form's own rounding; u more below kTinyCos, the clamp's float). Its cut-off, the float nearest exp(-80 / k),
// moves k ln c by < k u
// <= 7.7e-6, inside the window above.
#include <lightskin/gi/lightskin/CpuLightSkin.h>

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace lightskin::test {
namespace {

constexpr double kU = 5.9604644775390625e-8; // 2^-24
constexpr double kEpsY = 7.6e-8 + 5.0 * kU;
constexpr double kEps2 = 1.7e-7 + 2.0 * kU;
constexpr double kMinLogPow = -80.0; // lightskin_math.glsl, G3
constexpr double kTinyCos = 1.0e-30;
constexpr double kMaxSquaringExponent = 128.0; // CpuGatherKernels.cpp

bool bySquaring(float k) { return k >= 1.0f && double(k) <= kMaxSquaringExponent && k == std::floor(k); }

double exactLobe(float c, float k) {
    if (!(c > 0.0f)) return 0.0;
    const double e = double(k) * std::log(std::max(std::min(double(c), 1.0), kTinyCos));
    return e < kMinLogPow ? 0.0 : std::exp(e);
}

/// Cosines: every 1223rd float from 1e-30 to 1, the last 20000 floats below 1 (where large k
/// lobes live), values above 1 (rounding of the mirror cosine), zero, negative, below 1e-30.
std::vector<float> cosines() {
    std::vector<float> c;
    const std::uint32_t low = std::bit_cast<std::uint32_t>(float(kTinyCos)), one = std::bit_cast<std::uint32_t>(1.0f);
    for (std::uint32_t b = low; b < one; b += 1223) c.push_back(std::bit_cast<float>(b));
    for (std::uint32_t b = one - 20000; b <= one; ++b) c.push_back(std::bit_cast<float>(b));
    for (float extra : {1.0000001f, 1.001f, 0.0f, -0.0f, -0.5f, -1.0f, 1e-31f, 1e-38f, 1e-45f}) c.push_back(extra);
    return c;
}

struct Result {
    double worstRelative = 0.0; ///< max |lobe / exact - 1| / bound over the lit values
    std::size_t lit = 0, checked = 0;
};

void check(const std::vector<float>& c, float k, const std::string& target, Result& result) {
    std::vector<float> exponent(c.size(), k), out(c.size(), -1.0f);
    gi::cpuLobePow(c, exponent, out);
    for (std::size_t i = 0; i < c.size(); ++i) {
        const double exact = exactLobe(c[i], k);
        const double lobe = double(out[i]);
        ++result.checked;
        if (!(c[i] > 0.0f)) {
            ASSERT_EQ(out[i], 0.0f) << target << ": c = " << c[i] << ", k = " << k;
            continue;
        }
        const double y = double(k) * std::log2(std::max(std::min(double(c[i]), 1.0), kTinyCos));
        // by squaring: below kTinyCos the clamp is float(kTinyCos), relative error <= u (only k = 1
        // is lit there)
        const double clamp = double(c[i]) < kTinyCos ? kU : 0.0;
        const double bound = bySquaring(k) ? 1.00001 * double(k - 1.0f) * kU + clamp + 1e-12
                                           : std::log(2.0) * kEpsY * std::abs(y) + kEps2;
        const double lnLobe = y * std::log(2.0);
        if (std::abs(lnLobe - kMinLogPow) <= kEpsY * 80.0 * 1.01) { // either side of the cut-off
            ASSERT_LE(lobe, 1.9e-35) << target << ": c = " << c[i] << ", k = " << k;
            continue;
        }
        if (exact == 0.0) {
            ASSERT_EQ(lobe, 0.0) << target << ": c = " << c[i] << ", k = " << k << " (below the cut-off)";
            continue;
        }
        ++result.lit;
        const double relative = std::abs(lobe / exact - 1.0);
        ASSERT_LE(relative, bound) << target << ": c = " << c[i] << " (bits " << std::bit_cast<std::uint32_t>(c[i])
                                   << "), k = " << k << ": lobe " << lobe << ", exact " << exact;
        result.worstRelative = std::max(result.worstRelative, relative / bound);
    }
}

TEST(CpuLobePowTest, MatchesTheClosedFormWithinTheDerivedBoundOnEveryInstructionSet) {
    const std::vector<float> c = cosines();
    // integers up to 128 by squaring (127: the most products), the rest and 129 by log2 and exp2
    const float exponents[] = {1.0f, 1.5f, 2.0f, 7.3f, 20.0f, 30.0f, 100.0f, 127.0f, 128.0f, 129.0f, 1000.0f, 1e4f};
    for (const std::string& target : gi::cpuSimdTargets()) {
        gi::setCpuSimdTarget(target);
        double worst = 0.0;
        std::size_t lit = 0;
        for (const float k : exponents) {
            Result r;
            check(c, k, target, r);
            if (HasFatalFailure()) break;
            worst = std::max(worst, r.worstRelative);
            lit += r.lit;
        }
        std::printf("%s: %zu lit values, worst error %.3f of the bound\n", target.c_str(), lit, worst);
        // the sweep must exercise the lit range, not only zeros (about half of the cosines with
        // k = 1 alone are lit)
        EXPECT_GT(lit, c.size() / 2) << target;
    }
    gi::setCpuSimdTarget("");
}

TEST(CpuLobePowTest, IsExactAtTheMirrorDirectionAndZeroBehind) {
    const std::vector<float> c = {1.0f, 0.0f, -0.25f, 1.5f};
    const std::vector<float> k = {1e4f, 30.0f, 1.0f, 7.0f};
    std::vector<float> out(c.size(), -1.0f);
    gi::cpuLobePow(c, k, out);
    EXPECT_EQ(out[0], 1.0f); // log2(1) = 0 exactly, 2^0 = 1 exactly
    EXPECT_EQ(out[1], 0.0f);
    EXPECT_EQ(out[2], 0.0f);
    EXPECT_EQ(out[3], 1.0f); // clamped to 1
}

} // namespace
} // namespace lightskin::test
