#pragma once
// The SIMD row kernel of BilateralDepthFilter (BilateralDepthKernel.cpp, compiled once per x86
// instruction set by Google Highway and dispatched at run time). Internal to capture.
#include <cstddef>
#include <string>

namespace lightskin::capture::detail {

/// The filter's taps besides the centre: neighbour offsets in floats from the centre in the padded
/// image, and log2 of their spatial weights (log2 exp(-r^2 / 2 sigma_space^2)).
struct BilateralTaps {
    const std::ptrdiff_t* offsets = nullptr;
    const float* log2Space = nullptr;
    std::size_t count = 0;
};

/// Filters `rows` rows of `width` pixels: in[row * inStride + x] is the centre of output pixel
/// (x, row), its taps at in[... + offsets[k]] (the caller pads the image by the kernel radius).
/// Depth in metres; a missing pixel holds a sentinel far beyond every depth, whose weight is 0:
/// out = 0 where the centre is missing, else (z0 + sum w_k z_k) / (1 + sum w_k) with
/// w_k = 2^(log2Space_k - (rangeScale (z_k - z0))^2), 0 where that exponent is below -126.
/// Reads up to `width` rounded up to the vector length past each centre row's start (the padding
/// must hold them); writes `width` floats per output row.
void bilateralRows(const float* in, std::size_t inStride, std::size_t rows, std::size_t width,
                   const BilateralTaps& taps, float rangeScale, float* out, std::size_t outStride);

/// The widest vector, in floats, any target uses (the padding the caller adds for the row tail).
inline constexpr std::size_t kMaxBilateralLanes = 16;

/// Name of the instruction set the dispatch chose (e.g. "AVX3").
std::string bilateralTargetName();

} // namespace lightskin::capture::detail
