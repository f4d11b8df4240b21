#pragma once
// A simple sparse-point set for tests and benchmarks: `count` mesh vertices chosen by
// farthest-point sampling (deterministic, starting at vertex 0), occluder radius = max distance
// to a vertex of the point's Voronoi region, 8 nearest sparse points per vertex by brute force.
// O(count x vertices): fine for test meshes; the project's SparsePointSampler is the real one.

#include <lightskin/core/TriangleMesh.h>
#include <lightskin/gi/common/SparsePointSet.h>

namespace lightskin::gi {

SparsePointSet sparsePointsFromVertices(const TriangleMesh& mesh, std::size_t count);

} // namespace lightskin::gi
