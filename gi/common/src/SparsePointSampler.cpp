#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/gi/common/SparsePointSampler.h>

#include <glm/geometric.hpp>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <random>
#include <string>
#include <unordered_map>

namespace lightskin::gi {

void validate(const SparsePointSettings& s) {
    const auto fail = [](const char* field, const std::string& why) {
        throw Error(std::string("SparsePointSettings.") + field, std::nullopt, why);
    };
    if (s.pointCount < 1 || s.pointCount > 65536) fail("pointCount", "must be in [1, 65536], got " + std::to_string(s.pointCount));
    if (s.candidatesPerPoint < 1 || s.candidatesPerPoint > 64) fail("candidatesPerPoint", "must be in [1, 64]");
    if (s.maxRefinedTriangles < 1) fail("maxRefinedTriangles", "must be positive");
}

namespace {

glm::dvec3 position(const TriangleMesh& mesh, std::size_t corner) { return glm::dvec3(mesh.positions[mesh.indices[corner]]); }

double triangleArea(const TriangleMesh& mesh, std::size_t t) {
    const glm::dvec3 a = position(mesh, 3 * t), b = position(mesh, 3 * t + 1), c = position(mesh, 3 * t + 2);
    return 0.5 * glm::length(glm::cross(b - a, c - a));
}

pcl::PointXYZ toPcl(const glm::dvec3& p) { return {float(p.x), float(p.y), float(p.z)}; }

struct Candidate {
    glm::dvec3 position;
    glm::dvec3 normal;
    SurfaceAnchor anchor;
};

// Area-uniform random points on the surface with interpolated vertex normals.
std::vector<Candidate> sampleCandidates(const TriangleMesh& mesh, std::size_t count, std::uint32_t seed) {
    const std::size_t triangles = mesh.triangleCount();
    std::vector<double> cumulative(triangles);
    double total = 0.0;
    for (std::size_t t = 0; t < triangles; ++t) cumulative[t] = (total += triangleArea(mesh, t));
    std::mt19937_64 random(seed);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    std::vector<Candidate> out(count);
    for (Candidate& candidate : out) {
        const double pick = uniform(random) * total;
        const std::size_t t = std::min<std::size_t>(
            std::size_t(std::upper_bound(cumulative.begin(), cumulative.end(), pick) - cumulative.begin()), triangles - 1);
        const double r1 = std::sqrt(uniform(random)), r2 = uniform(random);
        const double wa = 1.0 - r1, wb = r1 * (1.0 - r2), wc = r1 * r2;
        const glm::dvec3 a = position(mesh, 3 * t), b = position(mesh, 3 * t + 1), c = position(mesh, 3 * t + 2);
        candidate.position = wa * a + wb * b + wc * c;
        glm::dvec3 n = wa * glm::dvec3(mesh.normals[mesh.indices[3 * t]]) + wb * glm::dvec3(mesh.normals[mesh.indices[3 * t + 1]]) +
                       wc * glm::dvec3(mesh.normals[mesh.indices[3 * t + 2]]);
        if (!(glm::length(n) > 1e-12)) n = glm::cross(b - a, c - a); // opposing vertex normals: face normal
        candidate.normal = glm::normalize(n);
        candidate.anchor = {std::uint32_t(t), float(wb), float(wc)};
    }
    return out;
}

// Farthest-point sampling with lazy max-heap and kd-tree radius updates (see the header).
std::vector<std::uint32_t> farthestPoints(const std::vector<Candidate>& candidates, std::size_t count, std::uint32_t seed) {
    const std::size_t m = candidates.size();
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    cloud->resize(m);
    for (std::size_t i = 0; i < m; ++i) (*cloud)[i] = toPcl(candidates[i].position);
    pcl::KdTreeFLANN<pcl::PointXYZ> tree(false); // unsorted radius results: faster
    tree.setInputCloud(cloud);

    std::vector<float> minDistance2(m, std::numeric_limits<float>::infinity());
    std::vector<char> selected(m, 0);
    using Entry = std::pair<float, std::uint32_t>;
    std::priority_queue<Entry> heap;
    std::vector<std::uint32_t> out;
    out.reserve(count);
    pcl::Indices indices;
    std::vector<float> distances2;

    std::uint32_t pick = std::uint32_t(std::mt19937(seed)() % m);
    for (std::size_t k = 0; k < count; ++k) {
        if (k > 0) {
            for (;;) {
                LIGHTSKIN_ASSERT(!heap.empty(), "fewer distinct candidates than points");
                const Entry top = heap.top();
                heap.pop();
                if (!selected[top.second] && top.first == minDistance2[top.second]) {
                    pick = top.second;
                    break;
                }
            }
        }
        const float radius2 = minDistance2[pick];
        selected[pick] = 1;
        minDistance2[pick] = 0.0f;
        out.push_back(pick);
        const pcl::PointXYZ& p = (*cloud)[pick];
        if (k == 0) {
            for (std::uint32_t j = 0; j < m; ++j) {
                const glm::dvec3 d = candidates[j].position - candidates[pick].position;
                minDistance2[j] = float(glm::dot(d, d));
                if (!selected[j]) heap.emplace(minDistance2[j], j);
            }
            continue;
        }
        // Only candidates closer to p than to every earlier point change; all lie within sqrt(radius2).
        if (!(radius2 > 0.0f)) continue; // duplicates of selected points: nothing to update
        tree.radiusSearch(p, double(std::sqrt(radius2)), indices, distances2);
        for (std::size_t i = 0; i < indices.size(); ++i) {
            const auto j = std::uint32_t(indices[i]);
            if (distances2[i] < minDistance2[j]) {
                minDistance2[j] = distances2[i];
                if (!selected[j]) heap.emplace(distances2[i], j);
            }
        }
    }
    return out;
}

std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b) {
    if (a > b) std::swap(a, b);
    return (std::uint64_t(a) << 32) | b;
}

} // namespace

double surfaceArea(const TriangleMesh& mesh) {
    double total = 0.0;
    for (std::size_t t = 0; t < mesh.triangleCount(); ++t) total += triangleArea(mesh, t);
    return total;
}

double longestEdge(const TriangleMesh& mesh) {
    double longest = 0.0;
    for (std::size_t t = 0; t < mesh.triangleCount(); ++t)
        for (std::size_t e = 0; e < 3; ++e)
            longest = std::max(longest, glm::length(position(mesh, 3 * t + e) - position(mesh, 3 * t + (e + 1) % 3)));
    return longest;
}

double nominalSpacing(const TriangleMesh& mesh, int pointCount) {
    LIGHTSKIN_ASSERT(pointCount > 0, "pointCount must be positive");
    return std::sqrt(surfaceArea(mesh) / pointCount);
}

int refineMeshToEdgeLength(TriangleMesh& mesh, double maxEdge, std::size_t maxTriangles) {
    LIGHTSKIN_ASSERT(maxEdge > 0.0, "maxEdge must be positive");
    const bool hasTexcoords = !mesh.texcoords.empty();
    int passes = 0;
    for (;;) {
        std::unordered_map<std::uint64_t, std::uint32_t> midpoints;
        std::size_t newTriangles = 0;
        const std::size_t triangles = mesh.triangleCount();
        for (std::size_t t = 0; t < triangles; ++t) {
            int split = 0;
            for (std::size_t e = 0; e < 3; ++e) {
                const std::uint32_t a = mesh.indices[3 * t + e], b = mesh.indices[3 * t + (e + 1) % 3];
                if (glm::length(glm::dvec3(mesh.positions[a]) - glm::dvec3(mesh.positions[b])) > maxEdge) {
                    ++split;
                    midpoints.emplace(edgeKey(a, b), 0u);
                }
            }
            newTriangles += std::size_t(split); // a triangle with k split edges becomes k + 1
        }
        if (midpoints.empty() || triangles + newTriangles > maxTriangles) return passes;
        for (auto& [key, vertex] : midpoints) {
            const auto a = std::uint32_t(key >> 32), b = std::uint32_t(key & 0xffffffffu);
            vertex = std::uint32_t(mesh.positions.size());
            mesh.positions.push_back(0.5f * (mesh.positions[a] + mesh.positions[b]));
            const glm::vec3 n = mesh.normals[a] + mesh.normals[b];
            const float length = glm::length(n);
            mesh.normals.push_back(length > 1e-6f ? n / length : mesh.normals[a]);
            if (hasTexcoords) mesh.texcoords.push_back(0.5f * (mesh.texcoords[a] + mesh.texcoords[b]));
        }
        std::vector<std::uint32_t> indices;
        indices.reserve(3 * (triangles + newTriangles));
        const auto emit = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) { indices.insert(indices.end(), {a, b, c}); };
        for (std::size_t t = 0; t < triangles; ++t) {
            std::uint32_t v[3] = {mesh.indices[3 * t], mesh.indices[3 * t + 1], mesh.indices[3 * t + 2]};
            std::uint32_t m[3];
            bool isSplit[3];
            int split = 0;
            for (int e = 0; e < 3; ++e) {
                const auto it = midpoints.find(edgeKey(v[e], v[(e + 1) % 3]));
                isSplit[e] = it != midpoints.end();
                m[e] = isSplit[e] ? it->second : 0u;
                split += isSplit[e] ? 1 : 0;
            }
            if (split == 0) {
                emit(v[0], v[1], v[2]);
            } else if (split == 3) {
                emit(v[0], m[0], m[2]);
                emit(m[0], v[1], m[1]);
                emit(m[2], m[1], v[2]);
                emit(m[0], m[1], m[2]);
            } else if (split == 1) {
                const int e = isSplit[0] ? 0 : isSplit[1] ? 1 : 2; // split edge v[e] -> v[e+1]
                const std::uint32_t a = v[e], b = v[(e + 1) % 3], c = v[(e + 2) % 3];
                emit(a, m[e], c);
                emit(m[e], b, c);
            } else {
                const int free = !isSplit[0] ? 0 : !isSplit[1] ? 1 : 2; // unsplit edge, rotated to c -> a
                const int e0 = (free + 1) % 3, e1 = (free + 2) % 3;     // a -> b, b -> c are split
                const std::uint32_t a = v[e0], b = v[e1], c = v[free];
                const std::uint32_t mab = m[e0], mbc = m[e1];
                emit(mab, b, mbc);
                emit(a, mab, mbc);
                emit(a, mbc, c);
            }
        }
        mesh.indices = std::move(indices);
        ++passes;
    }
}

SparsePointSet sampleSparsePoints(const TriangleMesh& mesh, const SparsePointSettings& settings, const std::string& meshName) {
    validate(settings);
    mesh.validate(meshName);
    const double area = surfaceArea(mesh);
    if (!(area > 0.0) || !std::isfinite(area)) throw Error(meshName, std::nullopt, "mesh has no surface area");
    const auto n = std::size_t(settings.pointCount);
    const std::size_t m = std::max<std::size_t>(n * std::size_t(settings.candidatesPerPoint), 4096);
    const std::vector<Candidate> candidates = sampleCandidates(mesh, m, settings.seed);
    const std::vector<std::uint32_t> chosen = farthestPoints(candidates, n, settings.seed);

    SparsePointSet set;
    set.points.resize(n);
    set.anchors.resize(n);
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    cloud->resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        set.points[i].position = glm::vec3(candidates[chosen[i]].position);
        set.points[i].normal = glm::vec3(candidates[chosen[i]].normal);
        set.anchors[i] = candidates[chosen[i]].anchor;
        (*cloud)[i] = toPcl(candidates[chosen[i]].position);
    }
    pcl::KdTreeFLANN<pcl::PointXYZ> tree;
    tree.setInputCloud(cloud);
    const auto k = unsigned(std::min<std::size_t>(n, std::size_t(kVertexNeighbours)));
    pcl::Indices indices;
    std::vector<float> distances2;
    std::vector<float> radius(n, 0.0f);
    std::vector<char> ownsVertex(n, 0);
    set.vertexNeighbours.resize(mesh.vertexCount());
    for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
        const glm::vec3& p = mesh.positions[v];
        tree.nearestKSearch(toPcl(glm::dvec3(p)), k, indices, distances2);
        auto& neighbours = set.vertexNeighbours[v];
        for (int j = 0; j < kVertexNeighbours; ++j)
            neighbours[std::size_t(j)] = std::uint32_t(indices[std::size_t(std::min(j, int(indices.size()) - 1))]);
        // Voronoi owner = nearest sparse point: its occluder disc must reach this vertex.
        radius[neighbours[0]] = std::max(radius[neighbours[0]], std::sqrt(distances2[0]));
        ownsVertex[neighbours[0]] = 1;
    }
    // Points that own no vertex (mesh coarser than the points): the farthest surface candidate in
    // their Voronoi region stands in for the farthest vertex.
    if (std::find(ownsVertex.begin(), ownsVertex.end(), 0) != ownsVertex.end()) {
        for (const Candidate& candidate : candidates) {
            tree.nearestKSearch(toPcl(candidate.position), 1, indices, distances2);
            const auto owner = std::size_t(indices[0]);
            if (!ownsVertex[owner]) radius[owner] = std::max(radius[owner], std::sqrt(distances2[0]));
        }
    }
    for (std::size_t i = 0; i < n; ++i) set.points[i].occluderRadius = radius[i];
    set.tessellationRatio = float(longestEdge(mesh) / std::sqrt(area / double(n)));
    return set;
}

void followSurfaceInto(const TriangleMesh& mesh, std::span<const SurfaceAnchor> anchors,
                       std::span<SparsePoint> points) {
    LIGHTSKIN_ASSERT(anchors.size() == points.size(), "one anchor per point");
    for (std::size_t i = 0; i < points.size(); ++i) {
        const SurfaceAnchor& anchor = anchors[i];
        LIGHTSKIN_ASSERT(anchor.triangle < mesh.triangleCount(), "an anchor's triangle is not in the mesh");
        const std::uint32_t* corner = &mesh.indices[3 * std::size_t(anchor.triangle)];
        const float wa = 1.0f - anchor.u - anchor.v;
        const glm::vec3 &a = mesh.positions[corner[0]], &b = mesh.positions[corner[1]], &c = mesh.positions[corner[2]];
        points[i].position = wa * a + anchor.u * b + anchor.v * c;
        glm::vec3 n =
            wa * mesh.normals[corner[0]] + anchor.u * mesh.normals[corner[1]] + anchor.v * mesh.normals[corner[2]];
        if (!(glm::length(n) > 1e-12f)) n = glm::cross(b - a, c - a);
        points[i].normal = glm::normalize(n);
    }
}

void refitOccluderRadiiInto(const TriangleMesh& mesh,
                            std::span<const std::array<std::uint32_t, kVertexNeighbours>> vertexNeighbours,
                            std::span<SparsePoint> points) {
    LIGHTSKIN_ASSERT(vertexNeighbours.size() == mesh.vertexCount(), "one neighbour list per vertex");
    for (const auto& neighbours : vertexNeighbours) points[neighbours[0]].occluderRadius = 0.0f; // owners only
    for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
        SparsePoint& owner = points[vertexNeighbours[v][0]];
        owner.occluderRadius = std::max(owner.occluderRadius, glm::length(mesh.positions[v] - owner.position));
    }
}

SparsePointSet prepareSparsePoints(TriangleMesh& mesh, const SparsePointSettings& settings, const std::string& meshName) {
    validate(settings);
    mesh.validate(meshName);
    const double spacing = nominalSpacing(mesh, settings.pointCount);
    if (settings.refine && longestEdge(mesh) > spacing) {
        const std::size_t before = mesh.triangleCount();
        const int passes = refineMeshToEdgeLength(mesh, spacing, settings.maxRefinedTriangles);
        const double ratio = longestEdge(mesh) / spacing;
        const std::string what = meshName + ": refined " + std::to_string(before) + " -> " +
                                 std::to_string(mesh.triangleCount()) + " triangles in " + std::to_string(passes) +
                                 " passes for " + std::to_string(settings.pointCount) + " sparse points";
        if (ratio > 1.0)
            log::warning(what + "; the cap of " + std::to_string(settings.maxRefinedTriangles) +
                         " triangles leaves edges " + std::to_string(ratio) + "x the sparse-point spacing");
        else
            log::info(what);
    }
    return sampleSparsePoints(mesh, settings, meshName);
}

SparsePointProvider samplingProvider(const SparsePointSettings& settings) {
    validate(settings);
    return [settings](const MeshInstance& instance) {
        LIGHTSKIN_ASSERT(instance.mesh != nullptr, "a MeshInstance needs its CPU mesh for sparse-point sampling");
        return sampleSparsePoints(*instance.mesh, settings, "mesh " + std::to_string(instance.meshId));
    };
}

} // namespace lightskin::gi
