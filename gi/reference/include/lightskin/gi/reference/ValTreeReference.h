#pragma once
// Double-precision reference of the gather with a cut through the VAL tree: the same walk
// as gi/lightskin/shaders/gather_tree.comp, the same formulas (gi/lightskin/shaders/val_tree_math.glsl). Each receiver
// walks the tree depth first, the nearer child first; a leaf adds its VAL exactly (eq. 3-5, 7 as
// reference::gatherInto); an inner cluster is taken as one light when its error bound U (per channel,
// diffuse and, with `glossy`, glossy) is <= threshold x the receiver's running sum of what it has taken
// so far, else the walk descends. threshold 0 takes only clusters with U = 0 (wholly below the
// receiver's horizon or behind their emitting side: they add exactly 0), so it is the flat gather up to
// the order of the sums. The certified bound: |L'_cut - L'_flat| <= sum of U over the taken clusters,
// per channel (returned per receiver).
// eps_l (eq. 7): a taken cluster adds count x eps_l to the weights at its representative position.

#include <lightskin/gi/reference/LightSkinReference.h>
#include <lightskin/gi/lightskin/ValTree.h>

#include <cstdint>
#include <span>
#include <vector>

namespace lightskin::gi::reference {

using gather::CutBound;
using gather::CutStatistics;

/// The bound U of one cluster at one receiver (val_tree_math.glsl): sum_j E_j and the cluster's
/// approximation both lie in [0, U] per channel. `glossy` as GatherParameters::glossy.
CutBound clusterErrorBound(const ValClusterD& cluster, const Receiver& receiver, const glm::dvec3& eye,
                           const GatherParameters& parameters);

/// The eq.-7 sums of a cluster taken as one light at a receiver (what a cut adds for it).
GatherSums clusterAsOneLight(const ValClusterD& cluster, const Receiver& receiver, const glm::dvec3& eye,
                             const GatherParameters& parameters);

/// `tree` must be built from `lights` (buildValTreeInto). `out` (and `bounds` if not null) resized to
/// receivers.size(). threshold >= 0.
void gatherWithCutInto(const ValTreeD& tree, std::span<const VirtualAreaLight> lights,
                       std::span<const Receiver> receivers, const glm::dvec3& eye, const GatherParameters& parameters,
                       double threshold, std::vector<GatherSums>& out, std::vector<CutBound>* bounds = nullptr,
                       CutStatistics* statistics = nullptr);

} // namespace lightskin::gi::reference
