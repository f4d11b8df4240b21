#pragma once
// A cluster tree over a VAL set: each node stands for the VALs below it (total flux, representative
// position and normal, bounding box, normal cone), so that a gather can take a far or dim cluster as one light (a
// "cut", as in lightcuts). Approximation and error bound: gi/lightskin/shaders/val_tree_math.glsl.
// Layout: node 0 is the root, an inner node has two children (always after their parent), a leaf is one valid VAL
// (index into the input span); invalid VALs (area <= 0 or NaN) are left out, so an empty or all-invalid set gives
// an empty tree. A traversal stack of kValTreeMaxDepth entries always suffices. Units and frames as
// VirtualAreaLight: world metres, m^2, linear RGB W; angles in radians. The two CPU builders (BVH, depth-image
// quadtree; the GPU one is GpuValQuadtree.h), their node order and cost: docs/LIGHTSKIN.md, "Gather with a cut
// through the VAL tree".

#include <lightskin/gi/common/VirtualAreaLight.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace lightskin::gi {

/// A traversal never needs more stack entries than this (checked by the builder: 2^62 VALs).
inline constexpr int kValTreeMaxDepth = 64;
/// ValClusterT::child1 of a leaf; its child0 is then the VAL's index in the input span.
inline constexpr std::uint32_t kValTreeLeaf = 0xFFFFFFFFu;

/// One node. Real = float: the GPU layout (std430, seven 16-byte rows, gi/lightskin/shaders/gather_tree.comp);
/// Real = double: the reference's (tests, error measurement).
template <class Real>
struct ValClusterT {
    using Vec3 = glm::vec<3, Real, glm::defaultp>;
    Vec3 position{0};     ///< flux-weighted mean VAL position (flux: channel sum), metres
    Real r2Mean = 0;      ///< sum r_j^4 / sum r_j^2, m^2 (r_j^2 = area_j / pi)
    Vec3 axis{0, 0, 1};   ///< unit normal cone axis = normalize(sum phi_j n_j)
    Real normalScale = 1; ///< |sum phi_j n_j| / sum phi_j, in [0, 1]
    Vec3 flux{0};         ///< total flux, linear RGB W
    Real r2Sum = 0;       ///< sum r_j^2, m^2
    Vec3 boxMin{0};       ///< of the VAL positions, metres
    Real coneAngle = 0;   ///< half angle of the cone around `axis` holding every n_j, radians (<= pi)
    Vec3 boxMax{0};
    Real r2Min = 0;                      ///< min r_j^2, m^2
    Vec3 variance{0};                    ///< flux-weighted variance of the positions per axis, m^2
    Real count = 0;                      ///< number of VALs below
    std::uint32_t child0 = 0;            ///< first child, or the VAL index for a leaf
    std::uint32_t child1 = kValTreeLeaf; ///< second child, or kValTreeLeaf
    std::uint32_t padding0 = 0, padding1 = 0;
};
using ValCluster = ValClusterT<float>;
using ValClusterD = ValClusterT<double>;
static_assert(sizeof(ValCluster) == 112, "ValCluster must match the std430 layout of gather_tree.comp");

/// The tree plus the builder's scratch; reuse one object per frame: building allocates only while
/// the VAL count grows past the largest seen.
template <class Real>
struct ValTreeT {
    std::vector<ValClusterT<Real>> nodes;    ///< nodes[0] = root; empty when no VAL is valid
    int depth = 0;                           ///< levels (a single leaf: 1)
    std::vector<std::uint32_t> scratchOrder; ///< builder scratch
    // quadtree builder scratch: one image level's cells (-1 = empty) and its non-empty clusters
    std::vector<std::int32_t> scratchCells[2];
    std::vector<ValClusterT<double>> scratchLevel[2];
    std::vector<std::uint32_t> scratchRows;
};
using ValTree = ValTreeT<float>;
using ValTreeD = ValTreeT<double>;

/// Builds the tree of `vals` into `tree` (see the file comment). O(n log n).
template <class Real>
void buildValTreeInto(std::span<const VirtualAreaLight> vals, ValTreeT<Real>& tree);

/// Builds the quadtree of VALs that come from the pixels of a width x height image into `tree`:
/// keys[i] = v * width + u names VAL i's pixel (ValSetView::keys, e.g. ValGenerator's depth pixel
/// index). Image levels pair neighbouring pixels alternately along u and v (two binary levels per 2x2
/// quadtree level, Morton order, so nodes keep two children); a cluster with one non-empty child IS
/// that child, so empty and invalid pixels add no nodes: 2 n - 1 nodes for n valid VALs, as the BVH.
/// O(width * height + n), one thread. Throws Error("VAL keys", ...) when a valid VAL's
/// key is outside the image or two valid VALs share a pixel; keys.size() must equal vals.size().
template <class Real>
void buildValQuadtreeInto(std::span<const VirtualAreaLight> vals, std::span<const std::uint32_t> keys,
                          std::uint32_t width, std::uint32_t height, ValTreeT<Real>& tree);

extern template void buildValTreeInto<float>(std::span<const VirtualAreaLight>, ValTreeT<float>&);
extern template void buildValTreeInto<double>(std::span<const VirtualAreaLight>, ValTreeT<double>&);
extern template void buildValQuadtreeInto<float>(std::span<const VirtualAreaLight>, std::span<const std::uint32_t>,
                                                 std::uint32_t, std::uint32_t, ValTreeT<float>&);
extern template void buildValQuadtreeInto<double>(std::span<const VirtualAreaLight>, std::span<const std::uint32_t>,
                                                  std::uint32_t, std::uint32_t, ValTreeT<double>&);

} // namespace lightskin::gi
