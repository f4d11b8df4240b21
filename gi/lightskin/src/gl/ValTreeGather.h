#pragma once
// The GL path's gather with a cut through the VAL tree (gi/lightskin/shaders/gather_tree.comp): for
// VALs keyed by image pixels (depth VALs) the image's quadtree, built on the GPU (GpuValQuadtree: no
// read-back); for any other set the BVH, built on the CPU from a read-back of the VAL buffer and
// uploaded. Then it runs the walk in dispatches of bounded length until every sparse point is done. Writes the same
// five gather targets as the flat gather. Buffers grow (logged) with the VAL and sparse-point counts and are reused; no
// allocation once they have grown.
#include "common/src/GatherShaders.h"

#include <lightskin/gi/lightskin/GpuValQuadtree.h>
#include <lightskin/gi/lightskin/ValTree.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/gl/ShaderLibrary.h>

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>

namespace lightskin::gi::detail {

/// What the last run did (whole frame, all sparse points).
struct ValTreeGatherStats {
    std::uint32_t nodes = 0;   ///< tree nodes (2 x valid VALs - 1)
    std::uint64_t visited = 0; ///< nodes visited, summed over the sparse points
    std::uint64_t taken = 0;   ///< lights taken (clusters + VALs): the cut sizes, summed
    std::uint32_t dispatches = 0;
    double buildMs = 0.0;  ///< wall clock: GPU quadtree passes, or BVH read-back, build and upload
    bool quadtree = false; ///< the image quadtree (keyed VALs), else the BVH
};

class ValTreeGather {
public:
    /// Compiles the four variants of gather_tree.comp.
    void buildPrograms(const gl::ShaderLibrary& library, bool nearField); ///< nearField: guard G12
    /// The quadtree of the last run() (when stats().quadtree): for tests and benchmarks.
    const GpuValQuadtree& quadtree() const noexcept { return quadtree_; }
    /// Gathers `count` VALs of `valBuffer` (std430 VirtualAreaLight) at `pointCount` sparse points into
    /// `targets` (the five rgba32f gather targets, cleared by the caller). threshold > 0. keyBuffer != 0
    /// and keyWidth > 0: one uint pixel key per VAL in a keyWidth x (keyCount / keyWidth) image (ValSetView):
    /// the quadtree is built; else the BVH.
    void run(std::uint32_t valBuffer, std::uint32_t count, std::uint32_t keyBuffer, std::uint32_t keyWidth,
             std::uint32_t keyCount, std::uint32_t pointCount, std::uint32_t pointPosition, std::uint32_t pointNormal,
             const std::array<std::uint32_t, 5>& targets, const glm::vec3& eye, float c, bool glossy, bool moments,
             float threshold, int stepsPerDispatch);
    const ValTreeGatherStats& stats() const noexcept { return stats_; }

private:
    void reserve(std::uint32_t valCount, std::uint32_t pointCount);
    gl::Program programs_[2][2];
    ValTree tree_;            // the BVH (CPU)
    GpuValQuadtree quadtree_; // keyed sets
    std::vector<VirtualAreaLight> vals_;
    gl::Buffer nodes_, walk_, stackD_, stackS_, stackNode_, counters_;
    std::uint32_t nodeCapacity_ = 0, pointCapacity_ = 0;
    ValTreeGatherStats stats_;
};

} // namespace lightskin::gi::detail
