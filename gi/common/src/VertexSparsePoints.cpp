#include <lightskin/core/Error.h>
#include <lightskin/gi/common/VertexSparsePoints.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <limits>
#include <numeric>

namespace lightskin::gi {

SparsePointSet sparsePointsFromVertices(const TriangleMesh& mesh, std::size_t count) {
    const std::size_t n = mesh.vertexCount();
    LIGHTSKIN_ASSERT(n > 0 && mesh.normals.size() == n, "lightskin::gi::sparsePointsFromVertices(): mesh needs vertices and normals");
    count = std::clamp<std::size_t>(count, 1, n);
    std::vector<std::size_t> chosen{0};
    std::vector<float> nearest(n, std::numeric_limits<float>::max());
    std::vector<std::uint32_t> owner(n, 0);
    for (std::size_t c = 0;; ++c) {
        const glm::vec3 p = mesh.positions[chosen[c]];
        for (std::size_t v = 0; v < n; ++v) {
            const float d = glm::length(mesh.positions[v] - p);
            if (d < nearest[v]) {
                nearest[v] = d;
                owner[v] = std::uint32_t(c);
            }
        }
        if (chosen.size() == count) break;
        chosen.push_back(std::size_t(std::max_element(nearest.begin(), nearest.end()) - nearest.begin()));
    }
    SparsePointSet set;
    set.points.resize(count);
    for (std::size_t c = 0; c < count; ++c) {
        set.points[c].position = mesh.positions[chosen[c]];
        set.points[c].normal = glm::normalize(mesh.normals[chosen[c]]);
    }
    for (std::size_t v = 0; v < n; ++v)
        set.points[owner[v]].occluderRadius = std::max(set.points[owner[v]].occluderRadius, nearest[v]);
    set.vertexNeighbours.resize(n);
    std::vector<std::pair<float, std::uint32_t>> order(count);
    for (std::size_t v = 0; v < n; ++v) {
        for (std::size_t c = 0; c < count; ++c)
            order[c] = {glm::length(mesh.positions[v] - set.points[c].position), std::uint32_t(c)};
        const std::size_t k = std::min<std::size_t>(count, kVertexNeighbours);
        std::partial_sort(order.begin(), order.begin() + std::ptrdiff_t(k), order.end());
        for (std::size_t j = 0; j < std::size_t(kVertexNeighbours); ++j)
            set.vertexNeighbours[v][j] = order[std::min(j, k - 1)].second;
    }
    float longestEdge = 0.0f;
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3)
        for (int e = 0; e < 3; ++e)
            longestEdge = std::max(longestEdge, glm::length(mesh.positions[mesh.indices[t + std::size_t(e)]] -
                                                            mesh.positions[mesh.indices[t + std::size_t((e + 1) % 3)]]));
    float spacing = 0.0f;
    for (const SparsePoint& p : set.points) spacing += p.occluderRadius;
    spacing /= float(count);
    set.tessellationRatio = spacing > 0.0f ? longestEdge / spacing : 0.0f;
    return set;
}

} // namespace lightskin::gi
