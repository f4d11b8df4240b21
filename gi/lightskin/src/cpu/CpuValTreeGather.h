#pragma once
// CpuLightSkin's gather with a cut through the VAL tree (LightSkinSettings::valTreeThreshold
// > 0): the tree of the frame's VALs (double, ValTree.h) and, per sparse point, the walk of the double
// reference (gi/lightskin/src/ValTreeWalk.h), threads over the points. Writes the flat gather's sum
// layout (CpuGatherKernels.h, kGatherSums, eps_l not included). Kept apart from the flat SIMD kernels
// (CpuGatherKernels.cpp): the walk is branchy, per point, and not vectorised across points.
#include <lightskin/gi/common/VirtualAreaLight.h>
#include <lightskin/gi/lightskin/ValTree.h>

#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <span>

namespace lightskin::gi::cpu {

/// VALs from the pixels of a width x height image: keys[i] = v * width + u (buildValQuadtreeInto);
/// empty keys: any VAL set (the BVH).
struct ValTreeImage {
    std::span<const std::uint32_t> keys;
    std::uint32_t width = 0, height = 0;
};

struct ValTreeCutStats {
    std::uint32_t nodes = 0;   ///< tree nodes
    bool quadtree = false;     ///< the image quadtree, else the BVH
    std::uint64_t visited = 0; ///< nodes visited, summed over the points
    std::uint64_t taken = 0;   ///< lights taken (cut sizes), summed over the points
};

class ValTreeCut {
public:
    /// Builds the tree of `lights` (reusing its storage; the quadtree when `image` has keys, else the
    /// BVH) and writes point i's sums to sums[s * stride + i], s < kGatherSums. threshold > 0; c: c of
    /// c_k = c (k + 1); nearField: guard G12 of lightskin_math.glsl. Throws Error("VAL keys", ...) on bad
    /// keys (buildValQuadtreeInto).
    void gather(std::span<const VirtualAreaLight> lights, std::span<const glm::dvec3> positions,
                std::span<const glm::dvec3> normals, std::span<const double> exponents, const glm::dvec3& eye, double c,
                bool glossy, bool moments, bool nearField, double threshold, int threads, float* sums,
                std::size_t stride, const ValTreeImage& image = {});
    const ValTreeCutStats& stats() const noexcept { return stats_; }

private:
    ValTreeD tree_;
    ValTreeCutStats stats_;
};

} // namespace lightskin::gi::cpu
