// Multi-scale PRT: the precompute (sec. 7 and 8 of the paper) and the per-frame CPU part (sec. 10).
// Formulas and model choices: gi/prt/include/lightskin/gi/prt/MultiscalePrt.h.
#include "PrtGeometry.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/prt/MultiscalePrt.h>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <random>
#include <string>

namespace lightskin::gi {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;
constexpr std::uint32_t kFormatVersion = 1; // part of the cache key: bump when the precompute's meaning changes

void checkRange(const char* field, long value, long lo, long hi) {
    if (value < lo || value > hi)
        throw Error("gi.multiscalePrt", std::nullopt,
                    std::string(field) + " = " + std::to_string(value) + " is outside [" + std::to_string(lo) + ", " +
                        std::to_string(hi) + "]");
}

// Uniform in [0, 1) from 53 random bits.
double uniform(std::mt19937_64& rng) { return double(rng() >> 11) * 0x1.0p-53; }

std::uint64_t mix(std::uint64_t seed, std::uint64_t index) {
    std::uint64_t z = seed * 0x9E3779B97F4A7C15ull + index + 0x632BE59BD9B4E019ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

// Orthonormal tangents of a unit normal (Duff et al. 2017).
void tangents(const glm::vec3& n, glm::vec3& t, glm::vec3& b) {
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float c = n.x * n.y * a;
    t = {1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x};
    b = {c, sign + n.y * n.y * a, -n.y};
}

// Cosine-distributed direction around n (pdf cos / pi): the Lambertian BRDF's importance sampling.
glm::vec3 cosineDirection(const glm::vec3& n, std::mt19937_64& rng) {
    const double u1 = uniform(rng), u2 = uniform(rng);
    const float r = float(std::sqrt(u1)), phi = float(2.0 * std::numbers::pi * u2);
    glm::vec3 t, b;
    tangents(n, t, b);
    return glm::normalize(r * std::cos(phi) * t + r * std::sin(phi) * b + float(std::sqrt(1.0 - u1)) * n);
}

struct Fnv {
    std::uint64_t value = 0xcbf29ce484222325ull;
    void bytes(const void* data, std::size_t size) {
        const auto* p = static_cast<const unsigned char*>(data);
        for (std::size_t i = 0; i < size; ++i) value = (value ^ p[i]) * 0x100000001b3ull;
    }
    template <class T>
    void pod(const T& v) {
        bytes(&v, sizeof v);
    }
};

// Spectral obscurance (sec. 8) at p: cosine-distributed rays; a ray that hits within `distance` is closed and
// adds rho(hit) / a (0 where a channel of the average albedo is 0), else open and adds 1.
glm::vec3 obscurance(const detail::PrtGeometry& scene, const glm::vec3& p, const glm::vec3& n, float distance, int rays,
                     float epsilon, const glm::vec3& averageAlbedo, std::uint64_t seed) {
    if (!(distance > 0.0f)) return glm::vec3(1.0f);
    std::mt19937_64 rng(seed);
    glm::dvec3 sum(0.0);
    const glm::vec3 origin = p + epsilon * n;
    for (int r = 0; r < rays; ++r) {
        const detail::PrtHit hit = scene.intersect(origin, cosineDirection(n, rng), 0.0f, distance);
        if (!hit.hit) {
            sum += glm::dvec3(1.0);
            continue;
        }
        for (int c = 0; c < 3; ++c) sum[c] += averageAlbedo[c] > 0.0f ? double(hit.albedo[c] / averageAlbedo[c]) : 0.0;
    }
    return glm::vec3(sum / double(rays));
}

// k-means (Lloyd) on (position / diagonal, normal): entry points close to each other and on similarly
// oriented surfaces share a cluster (sec. 7.3). Deterministic k-means++ seeding.
std::vector<std::uint32_t> clusterEntries(const std::vector<glm::vec3>& positions,
                                          const std::vector<glm::vec3>& normals, float diagonal, std::uint32_t k,
                                          std::uint64_t seed) {
    const std::size_t n = positions.size();
    const float scale = diagonal > 0.0f ? 1.0f / diagonal : 1.0f;
    std::vector<std::array<float, 6>> features(n);
    for (std::size_t i = 0; i < n; ++i)
        features[i] = {positions[i].x * scale, positions[i].y * scale, positions[i].z * scale,
                       0.5f * normals[i].x,    0.5f * normals[i].y,    0.5f * normals[i].z};
    const auto distance2 = [](const std::array<float, 6>& a, const std::array<float, 6>& b) {
        float s = 0.0f;
        for (std::size_t j = 0; j < 6; ++j) s += (a[j] - b[j]) * (a[j] - b[j]);
        return s;
    };
    std::mt19937_64 rng(seed);
    std::vector<std::array<float, 6>> centres;
    centres.push_back(features[std::size_t(uniform(rng) * double(n)) % n]);
    std::vector<float> nearest(n, std::numeric_limits<float>::max());
    while (centres.size() < k) {
        double total = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
            nearest[i] = std::min(nearest[i], distance2(features[i], centres.back()));
            total += double(nearest[i]);
        }
        std::size_t pick = 0;
        if (total > 0.0) {
            double target = uniform(rng) * total;
            for (pick = 0; pick + 1 < n && target >= double(nearest[pick]); ++pick) target -= double(nearest[pick]);
        } else {
            pick = centres.size() % n; // all points equal: any choice
        }
        centres.push_back(features[pick]);
    }
    std::vector<std::uint32_t> assignment(n, 0);
    for (int iteration = 0; iteration < 30; ++iteration) {
        bool changed = false;
        for (std::size_t i = 0; i < n; ++i) {
            std::uint32_t best = 0;
            float bestD = std::numeric_limits<float>::max();
            for (std::uint32_t c = 0; c < k; ++c)
                if (const float d = distance2(features[i], centres[c]); d < bestD) bestD = d, best = c;
            changed |= assignment[i] != best;
            assignment[i] = best;
        }
        if (!changed && iteration > 0) break;
        std::vector<std::array<double, 6>> sums(k, std::array<double, 6>{});
        std::vector<std::size_t> counts(k, 0);
        for (std::size_t i = 0; i < n; ++i) {
            ++counts[assignment[i]];
            for (std::size_t j = 0; j < 6; ++j) sums[assignment[i]][j] += double(features[i][j]);
        }
        for (std::uint32_t c = 0; c < k; ++c) {
            if (counts[c] == 0) { // an empty cluster takes the point farthest from its centre
                std::size_t far = 0;
                float farD = -1.0f;
                for (std::size_t i = 0; i < n; ++i)
                    if (const float d = distance2(features[i], centres[assignment[i]]); d > farD) farD = d, far = i;
                centres[c] = features[far];
                assignment[far] = c;
                continue;
            }
            for (std::size_t j = 0; j < 6; ++j) centres[c][j] = float(sums[c][j] / double(counts[c]));
        }
    }
    return assignment;
}

} // namespace

void validate(const MultiscalePrtSettings& s) {
    checkRange("entryPoints", s.entryPoints, 1, 65536);
    checkRange("walksPerEntry", s.walksPerEntry, 1, 65536);
    checkRange("maxBounces", s.maxBounces, 0, 64);
    checkRange("clusters", s.clusters, 1, 65536);
    checkRange("basisVectors", s.basisVectors, 0, 64);
    checkRange("obscuranceRays", s.obscuranceRays, 1, 4096);
    checkRange("directGatherPoints", s.directGatherPoints, 0, 1 << 24);
    checkRange("directNeighbours", s.directNeighbours, 1, 16);
    if (!std::isfinite(s.entryLightFraction) || s.entryLightFraction < 0.0f || s.entryLightFraction > 0.99f)
        throw Error("gi.multiscalePrt", std::nullopt,
                    "entryLightFraction = " + std::to_string(s.entryLightFraction) +
                        " is outside [0, 0.99] (1 would leave surfaces the test points miss without entry points)");
    for (const glm::vec3& y : s.entryLightPoints)
        if (!std::isfinite(y.x) || !std::isfinite(y.y) || !std::isfinite(y.z))
            throw Error("gi.multiscalePrt", std::nullopt, "entryLightPoints holds a non-finite position");
    if (!std::isfinite(s.obscuranceDistance) || s.obscuranceDistance < 0.0f)
        throw Error("gi.multiscalePrt", std::nullopt, "obscuranceDistance must be a finite number >= 0 (metres)");
    if (!std::isfinite(s.minConnectionDistance) || s.minConnectionDistance < 0.0f)
        throw Error("gi.multiscalePrt", std::nullopt, "minConnectionDistance must be a finite number >= 0 (metres)");
}

std::size_t PrtData::byteSize() const noexcept {
    return exitOffsets.size() * 4 + (exitPositions.size() + exitNormals.size() + exitObscurance.size()) * 12 +
           (entryPositions.size() + entryNormals.size() + entryObscurance.size()) * 12 + entryCluster.size() * 4 +
           (clusterMaps.size() + entryWeights.size() + singularValues.size() + uncompressed.size()) * 4 +
           singularValueOffsets.size() * 4;
}

std::uint64_t prtCacheKey(std::span<const MeshInstance> instances, const MultiscalePrtSettings& s) {
    Fnv h;
    h.pod(kFormatVersion);
    for (const MeshInstance& instance : instances) {
        LIGHTSKIN_ASSERT(instance.mesh != nullptr, "lightskin::gi::prtCacheKey(): instance without a mesh");
        const TriangleMesh& mesh = *instance.mesh;
        h.pod(mesh.positions.size());
        h.bytes(mesh.positions.data(), mesh.positions.size() * sizeof(glm::vec3));
        h.bytes(mesh.normals.data(), mesh.normals.size() * sizeof(glm::vec3));
        h.pod(mesh.indices.size());
        h.bytes(mesh.indices.data(), mesh.indices.size() * sizeof(std::uint32_t));
        h.pod(instance.world_T_model);
        h.pod(instance.material.diffuseAlbedo);
    }
    h.pod(s.entryPoints);
    h.pod(s.walksPerEntry);
    h.pod(s.maxBounces);
    h.pod(s.clusters);
    h.pod(s.basisVectors);
    h.pod(s.obscuranceDistance);
    h.pod(s.obscuranceRays);
    h.pod(s.minConnectionDistance);
    h.pod(s.seed);
    h.pod(s.keepUncompressed);
    if (s.entryLightFraction > 0.0f && !s.entryLightPoints.empty()) { // uniform keys stay as they were
        h.pod(s.entryLightFraction);
        h.bytes(s.entryLightPoints.data(), s.entryLightPoints.size() * sizeof(glm::vec3));
    }
    return h.value;
}

PrtData precomputePrt(std::span<const MeshInstance> instances, const MultiscalePrtSettings& s) {
    validate(s);
    const auto start = std::chrono::steady_clock::now();
    PrtData data;
    data.key = prtCacheKey(instances, s);
    const detail::PrtGeometry scene = detail::PrtGeometry::create(instances);
    const auto& triangles = scene.triangles;
    const float epsilon = std::max(1e-6f, 1e-4f * scene.diagonal);
    const glm::vec3 averageAlbedo = scene.averageAlbedo;

    // Exit points: the vertices, world frame.
    for (const MeshInstance& instance : instances) {
        data.exitOffsets.push_back(std::uint32_t(data.exitPositions.size()));
        const glm::mat3 normalMatrix = glm::transpose(glm::inverse(glm::mat3(instance.world_T_model)));
        for (std::size_t v = 0; v < instance.mesh->vertexCount(); ++v) {
            data.exitPositions.push_back(
                glm::vec3(instance.world_T_model * glm::vec4(instance.mesh->positions[v], 1.0f)));
            const glm::vec3 n = normalMatrix * instance.mesh->normals[v];
            const float length = glm::length(n);
            data.exitNormals.push_back(length > 0.0f ? n / length : glm::vec3(0.0f, 0.0f, 1.0f));
        }
    }
    data.exitOffsets.push_back(std::uint32_t(data.exitPositions.size()));
    const std::size_t exits = data.exitPositions.size();
    const std::size_t mapSize = 3 * exits;

    // Entry points (sec. 7.1): a triangle t with probability P_t, then a uniform point in it, so the density is
    // p(x) = P_t / A_t. Uniform: P_t = A_t / A. Weighted: the mixture (1 - f) A_t / A + f w_t A_t / sum(w A), w_t
    // the paper's d(e) at the centroid: sum over test points Y of cos(theta) / |Y - c|^2 v(Y, c).
    double totalArea = 0.0;
    for (const detail::PrtTriangle& tri : triangles) totalArea += double(tri.area);
    std::vector<double> lightWeight(triangles.size(), 0.0);
    double weightedArea = 0.0;
    if (s.entryLightFraction > 0.0f && !s.entryLightPoints.empty()) {
#pragma omp parallel for schedule(dynamic, 64)
        for (std::ptrdiff_t ti = 0; ti < std::ptrdiff_t(triangles.size()); ++ti) {
            const detail::PrtTriangle& tri = triangles[std::size_t(ti)];
            const glm::vec3 centroid = (tri.a + tri.b + tri.c) / 3.0f;
            double w = 0.0;
            for (const glm::vec3& y : s.entryLightPoints) {
                const glm::vec3 d = y - centroid;
                const float d2 = glm::dot(d, d), cosine = glm::dot(tri.normal, d) / std::sqrt(d2);
                if (!(d2 > 0.0f) || !(cosine > 0.0f)) continue;
                if (scene.occluded(centroid + epsilon * tri.normal, y, epsilon)) continue;
                w += double(cosine) / double(d2);
            }
            lightWeight[std::size_t(ti)] = w;
        }
        for (std::size_t t = 0; t < triangles.size(); ++t) weightedArea += lightWeight[t] * double(triangles[t].area);
    }
    // No test point sees the meshes: the weighted part has nothing to say, sample uniformly.
    const double fraction = weightedArea > 0.0 ? double(s.entryLightFraction) : 0.0;
    std::vector<double> cumulative(triangles.size());
    double totalProbability = 0.0;
    for (std::size_t t = 0; t < triangles.size(); ++t) {
        const double area = double(triangles[t].area);
        // Uniform: the areas themselves (bit for bit the sampling before the weighting existed).
        const double probability =
            fraction > 0.0 ? (1.0 - fraction) * area / totalArea + fraction * lightWeight[t] * area / weightedArea
                           : area;
        cumulative[t] = totalProbability += probability;
    }
    if (triangles.empty()) { // no virtual content: nothing to transfer (render() writes zeros)
        data.singularValueOffsets.push_back(0);
        data.precomputeSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return data;
    }
    if (!(totalArea > 0.0)) throw Error("gi.multiscalePrt", std::nullopt, "the virtual meshes have no area");
    std::vector<glm::vec3> entryAlbedo;
    std::vector<double> entryInverseDensity; // 1 / p(x_e), m^2: the entry's share of the surface
    {
        std::mt19937_64 rng(mix(s.seed, 0xE17E));
        for (int e = 0; e < s.entryPoints; ++e) {
            const double target = uniform(rng) * totalProbability;
            const std::size_t t = std::min<std::size_t>(
                std::size_t(std::upper_bound(cumulative.begin(), cumulative.end(), target) - cumulative.begin()),
                triangles.size() - 1);
            double u = uniform(rng), v = uniform(rng);
            if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
            const auto& tri = triangles[t];
            data.entryPositions.push_back(tri.a + float(u) * (tri.b - tri.a) + float(v) * (tri.c - tri.a));
            data.entryNormals.push_back(tri.normal);
            entryAlbedo.push_back(instances[tri.instance].material.diffuseAlbedo);
            const double probability = cumulative[t] - (t > 0 ? cumulative[t - 1] : 0.0);
            entryInverseDensity.push_back(fraction > 0.0 ? double(tri.area) * totalProbability / probability
                                                         : totalArea);
        }
    }
    const std::size_t entries = data.entryPositions.size();

    // Medium scale: spectral obscurances of exit and entry points.
    data.exitObscurance.resize(exits);
    data.entryObscurance.resize(entries);
#pragma omp parallel for schedule(dynamic, 16)
    for (std::ptrdiff_t x = 0; x < std::ptrdiff_t(exits); ++x)
        data.exitObscurance[std::size_t(x)] = obscurance(
            scene, data.exitPositions[std::size_t(x)], data.exitNormals[std::size_t(x)], s.obscuranceDistance,
            s.obscuranceRays, epsilon, averageAlbedo, mix(s.seed, 0x0B5E0000ull + std::uint64_t(x)));
#pragma omp parallel for schedule(dynamic, 16)
    for (std::ptrdiff_t e = 0; e < std::ptrdiff_t(entries); ++e)
        data.entryObscurance[std::size_t(e)] = obscurance(
            scene, data.entryPositions[std::size_t(e)], data.entryNormals[std::size_t(e)], s.obscuranceDistance,
            s.obscuranceRays, epsilon, averageAlbedo, mix(s.seed, 0x0B5E1000000ull + std::uint64_t(e)));

    // Clusters of entry points.
    data.clusterCount = std::uint32_t(std::min<std::size_t>(std::size_t(s.clusters), entries));
    data.entryCluster =
        clusterEntries(data.entryPositions, data.entryNormals, scene.diagonal, data.clusterCount, mix(s.seed, 0xC1u));
    const int D = int(std::min<std::size_t>(std::size_t(s.basisVectors), mapSize));
    data.basisVectors = D;
    data.clusterMaps.assign(std::size_t(data.clusterCount) * std::size_t(D + 1) * mapSize, 0.0f);
    data.entryWeights.assign(entries * std::size_t(D), 0.0f);
    if (s.keepUncompressed) data.uncompressed.assign(entries * mapSize, 0.0f);

    // Connections shorter than the obscurance distance belong to the medium scale; else only the 1/d^2
    // singularity is cut.
    const float minDistance = s.obscuranceDistance > 0.0f ? s.obscuranceDistance : s.minConnectionDistance;
    // Unit irradiance times the entry's area share: 1 / (p(x_e) E W) (= A / (E W) when uniform), so that
    // sum_e I(x_e) T_e estimates the integral of I over the surfaces without bias whatever p is (p > 0 wherever
    // light can arrive: the uniform part of the mixture).
    const auto flux0 = [&](std::size_t e) {
        return entryInverseDensity[e] / double(entries) / double(s.walksPerEntry);
    };

    // One entry's transfer map (3 X floats): its random walks, each visited point connected to the exits.
    const auto transferRow = [&](std::size_t e, float* row) {
        std::fill(row, row + mapSize, 0.0f);
        std::mt19937_64 rng(mix(s.seed, 0x7A000000ull + e));
        std::vector<double> accumulator(mapSize, 0.0);
        const auto connect = [&](const glm::vec3& y, const glm::vec3& ny, const glm::dvec3& flux) {
            const glm::vec3 from = y + epsilon * ny;
            for (std::size_t x = 0; x < exits; ++x) {
                const glm::vec3 d = data.exitPositions[x] - y;
                const float d2 = glm::dot(d, d);
                if (d2 < minDistance * minDistance || !(d2 > 0.0f)) continue;
                const float length = std::sqrt(d2);
                const float cosY = glm::dot(ny, d) / length, cosX = -glm::dot(data.exitNormals[x], d) / length;
                if (cosY <= 0.0f || cosX <= 0.0f) continue;
                if (scene.occluded(from, data.exitPositions[x] + epsilon * data.exitNormals[x], epsilon)) continue;
                const double g = double(cosY * cosX) / (double(kPi) * double(d2));
                for (std::size_t c = 0; c < 3; ++c) accumulator[c * exits + x] += flux[int(c)] * g;
            }
        };
        for (int w = 0; w < s.walksPerEntry; ++w) {
            glm::vec3 y = data.entryPositions[e], ny = data.entryNormals[e];
            glm::dvec3 flux = glm::dvec3(entryAlbedo[e]) * flux0(e); // reflected by the entry's own BRDF
            connect(y, ny, flux);
            for (int bounce = 0; bounce < s.maxBounces; ++bounce) {
                const glm::vec3 direction = cosineDirection(ny, rng);
                const detail::PrtHit hit =
                    scene.intersect(y + epsilon * ny, direction, 0.0f, std::numeric_limits<float>::infinity());
                if (!hit.hit || !hit.frontFace) break; // left the scene, or entered a mesh from behind
                const float survival = std::min(1.0f, std::max({hit.albedo.x, hit.albedo.y, hit.albedo.z}));
                if (!(survival > 0.0f) || uniform(rng) >= double(survival)) break; // Russian roulette
                flux *= glm::dvec3(hit.albedo) / double(survival);
                y = y + epsilon * ny + hit.distance * direction;
                ny = hit.normal;
                connect(y, ny, flux);
            }
        }
        for (std::size_t i = 0; i < mapSize; ++i) row[i] = float(accumulator[i]);
    };

    // Per cluster: the rows of its entries, then PCA (mean + D principal maps; Eckart-Young: the squared
    // Frobenius error of the rank-D reconstruction is the sum of the discarded squared singular values).
    data.singularValueOffsets.push_back(0);
    for (std::uint32_t c = 0; c < data.clusterCount; ++c) {
        std::vector<std::size_t> members;
        for (std::size_t e = 0; e < entries; ++e)
            if (data.entryCluster[e] == c) members.push_back(e);
        Eigen::MatrixXf rows(Eigen::Index(members.size()), Eigen::Index(mapSize));
        std::vector<float> row(mapSize);
#pragma omp parallel for schedule(dynamic, 1) firstprivate(row)
        for (std::ptrdiff_t i = 0; i < std::ptrdiff_t(members.size()); ++i) {
            transferRow(members[std::size_t(i)], row.data());
            for (std::size_t j = 0; j < mapSize; ++j) rows(Eigen::Index(i), Eigen::Index(j)) = row[j];
        }
        if (s.keepUncompressed)
            for (std::size_t i = 0; i < members.size(); ++i)
                for (std::size_t j = 0; j < mapSize; ++j)
                    data.uncompressed[members[i] * mapSize + j] = rows(Eigen::Index(i), Eigen::Index(j));
        const Eigen::MatrixXd x = rows.cast<double>();
        const Eigen::RowVectorXd mean = x.colwise().mean();
        const Eigen::MatrixXd centred = x.rowwise() - mean;
        float* maps = data.clusterMaps.data() + std::size_t(c) * std::size_t(D + 1) * mapSize;
        for (std::size_t j = 0; j < mapSize; ++j) maps[j] = float(mean(Eigen::Index(j)));
        // The SVD through the eigen-decomposition of the smaller Gram matrix (sigma_k^2 its eigenvalues), not
        // Eigen 3.4.0's BDCSVD: its perturbCol0 indexes out of bounds on some of these rank-deficient matrices
        // (an assertion with asserts on, undefined behaviour without; orbit_prt at ~6000 entries), and
        // JacobiSVD is ~10 x slower. Squaring costs precision only in sigma_k << sigma_0, which are discarded.
        const Eigen::Index n = centred.rows(), m = centred.cols(), rank = std::min(n, m);
        const bool byRows = n <= m;
        const Eigen::MatrixXd gram =
            byRows ? Eigen::MatrixXd(centred * centred.transpose()) : Eigen::MatrixXd(centred.transpose() * centred);
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(gram);
        if (eigen.info() != Eigen::Success)
            throw Error("gi.multiscalePrt", std::nullopt,
                        "the PCA of cluster " + std::to_string(c) + " did not converge (non-finite transfer?)");
        const Eigen::VectorXd lambda = eigen.eigenvalues().reverse(); // descending
        const Eigen::MatrixXd vectors = eigen.eigenvectors().rowwise().reverse();
        Eigen::VectorXd sigma(rank);
        for (Eigen::Index k = 0; k < rank; ++k) sigma(k) = std::sqrt(std::max(0.0, lambda(k)));
        for (Eigen::Index k = 0; k < rank; ++k) data.singularValues.push_back(float(sigma(k)));
        for (Eigen::Index k = rank; k < D; ++k) data.singularValues.push_back(0.0f);
        data.singularValueOffsets.push_back(std::uint32_t(data.singularValues.size()));
        // A direction whose sigma is rounding noise of sigma_0 carries nothing: no basis map, zero weights.
        const double noise = 1e-7 * (rank > 0 ? sigma(0) : 0.0);
        for (Eigen::Index d = 0; d < std::min<Eigen::Index>(D, rank); ++d) {
            if (!(sigma(d) > noise)) break;
            const Eigen::VectorXd v = byRows ? Eigen::VectorXd(centred.transpose() * vectors.col(d) / sigma(d))
                                             : Eigen::VectorXd(vectors.col(d));
            float* basis = maps + std::size_t(d + 1) * mapSize;
            for (std::size_t j = 0; j < mapSize; ++j) basis[j] = float(v(Eigen::Index(j)));
            const Eigen::VectorXd weights = centred * v; // = u_d sigma_d
            for (std::size_t i = 0; i < members.size(); ++i)
                data.entryWeights[members[i] * std::size_t(D) + std::size_t(d)] = float(weights(Eigen::Index(i)));
        }
    }
    data.precomputeSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return data;
}

void reconstructTransferInto(const PrtData& data, std::size_t entry, std::span<float> out) {
    const std::size_t mapSize = 3 * data.exitCount(), D = std::size_t(data.basisVectors);
    LIGHTSKIN_ASSERT(out.size() == mapSize && entry < data.entryCount(),
                     "lightskin::gi::reconstructTransferInto(): one 3 X map for an existing entry");
    const float* maps = data.clusterMaps.data() + std::size_t(data.entryCluster[entry]) * (D + 1) * mapSize;
    for (std::size_t j = 0; j < mapSize; ++j) out[j] = maps[j];
    for (std::size_t d = 0; d < D; ++d) {
        const float w = data.entryWeights[entry * D + d];
        const float* basis = maps + (d + 1) * mapSize;
        for (std::size_t j = 0; j < mapSize; ++j) out[j] += w * basis[j];
    }
}

} // namespace lightskin::gi
