#pragma once
// Counter-based random numbers: every value is a pure function of (seed, a, b, c), so outputs do
// not depend on evaluation order, threads or the standard library's distributions (whose
// algorithms are implementation-defined): a recording regenerates bit for bit on any platform.

#include <cmath>
#include <cstdint>
#include <numbers>

namespace lightskin::synth {

/// SplitMix64 finaliser (Steele, Lea, Flood 2014): a bijective 64-bit mix with full avalanche.
constexpr std::uint64_t mix64(std::uint64_t x) noexcept {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

constexpr std::uint64_t hash4(std::uint64_t seed, std::uint64_t a, std::uint64_t b, std::uint64_t c) noexcept {
    return mix64(mix64(mix64(mix64(seed) ^ a) ^ b) ^ c);
}

/// Uniform in [0, 1), 53 random bits.
inline double uniform01(std::uint64_t seed, std::uint64_t a, std::uint64_t b, std::uint64_t c) noexcept {
    return double(hash4(seed, a, b, c) >> 11) * 0x1.0p-53;
}

/// Standard normal by Box-Muller from two independent uniforms.
inline double standardNormal(std::uint64_t seed, std::uint64_t a, std::uint64_t b, std::uint64_t c) noexcept {
    const double u1 = 1.0 - uniform01(seed, a, b, 2 * c); // (0, 1]: log is finite
    const double u2 = uniform01(seed, a, b, 2 * c + 1);
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

} // namespace lightskin::synth
