#include <lightskin/core/Error.h>
#include <lightskin/gi/reference/ImperfectVolumesReference.h>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace lightskin::gi::reference::volumes {
namespace {
constexpr double kPi = std::numbers::pi;
// Real SH constants: Y_0^0 = 1 / (2 sqrt(pi)), Y_1^m = sqrt(3 / (4 pi)) {y, z, x}.
const double kY0 = 0.5 / std::sqrt(kPi);
const double kY1 = std::sqrt(3.0 / (4.0 * kPi));
} // namespace

Sh4 shBasis(const glm::dvec3& d) { return {kY0, kY1 * d.y, kY1 * d.z, kY1 * d.x}; }

double shEvaluate(const Sh4& c, const glm::dvec3& d) {
    const Sh4 y = shBasis(d);
    return c[0] * y[0] + c[1] * y[1] + c[2] * y[2] + c[3] * y[3];
}

Sh4 shCosineLobe(const glm::dvec3& n) {
    const Sh4 y = shBasis(n);
    const double a0 = kPi, a1 = 2.0 * kPi / 3.0;
    return {a0 * y[0], a1 * y[1], a1 * y[2], a1 * y[3]};
}

double shIrradiance(const Sh4& radiance, const glm::dvec3& n) {
    const Sh4 lobe = shCosineLobe(n);
    return radiance[0] * lobe[0] + radiance[1] * lobe[1] + radiance[2] * lobe[2] + radiance[3] * lobe[3];
}

std::vector<glm::dvec3> stratifiedDirections(int count, double phiOffset) {
    LIGHTSKIN_ASSERT(count > 0, "lightskin::gi::reference::volumes::stratifiedDirections(): count must be > 0");
    const int bands = std::max(1, int(std::lround(std::sqrt(double(count)))));
    std::vector<glm::dvec3> out;
    out.reserve(std::size_t(count));
    for (int b = 0; b < bands; ++b) {
        const int begin = int((long(count) * b) / bands), end = int((long(count) * (b + 1)) / bands);
        const int cells = end - begin;
        // Band b spans z in [-1 + 2 begin / N, -1 + 2 end / N]: area 4 pi cells / N, so every cell
        // has 4 pi / N; the centre in z makes eq. 3 exact for Y_1^0 (linear in z).
        const double z = -1.0 + (double(begin) + double(end)) / double(count);
        const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
        for (int c = 0; c < cells; ++c) {
            const double phi = 2.0 * kPi * (double(c) + 0.5) / double(cells) + phiOffset;
            out.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
        }
    }
    return out;
}

Sh4 projectSh(const std::function<double(const glm::dvec3&)>& f, std::span<const glm::dvec3> directions) {
    Sh4 sum{};
    for (const glm::dvec3& d : directions) {
        const double value = f(d);
        const Sh4 y = shBasis(d);
        for (std::size_t i = 0; i < 4; ++i) sum[i] += value * y[i];
    }
    const double weight = 4.0 * kPi / double(directions.size());
    for (double& c : sum) c *= weight;
    return sum;
}

std::size_t Grid::voxelCount() const {
    return std::size_t(resolution) * std::size_t(resolution) * std::size_t(resolution);
}

glm::ivec3 Grid::voxelOf(const glm::dvec3& p) const {
    const glm::dvec3 q = (p - origin) / voxelSize;
    return {int(std::floor(q.x)), int(std::floor(q.y)), int(std::floor(q.z))};
}

bool Grid::inside(const glm::ivec3& v) const {
    return v.x >= 0 && v.y >= 0 && v.z >= 0 && v.x < resolution && v.y < resolution && v.z < resolution;
}

std::size_t Grid::index(const glm::ivec3& v) const {
    const std::size_t n = std::size_t(resolution);
    return (std::size_t(v.z) * n + std::size_t(v.y)) * n + std::size_t(v.x);
}

glm::dvec3 Grid::centre(const glm::ivec3& v) const { return origin + (glm::dvec3(v) + 0.5) * voxelSize; }

SurfacePoint pointFromVal(const VirtualAreaLight& val, const glm::dvec3& albedo) {
    SurfacePoint p;
    p.position = glm::dvec3(val.position);
    p.normal = glm::normalize(glm::dvec3(val.normal));
    p.radiance = val.area > 0.0f ? glm::dvec3(val.flux) / (kPi * double(val.area)) : glm::dvec3(0.0);
    p.albedo = albedo;
    p.emits = true;
    return p;
}

std::uint32_t pcgHash(std::uint32_t value) {
    const std::uint32_t state = value * 747796405u + 2891336453u;
    const std::uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

double unitFromHash(std::uint32_t hash) { return double(hash >> 8u) / 16777216.0; }

std::vector<SurfacePoint> sampleTriangles(const TriangleMesh& mesh, const glm::dmat4& world_T_model, int perTriangle,
                                          const glm::dvec3& albedo, std::uint32_t seed) {
    std::vector<SurfacePoint> out;
    const std::size_t triangles = mesh.indices.size() / 3;
    out.reserve(triangles * std::size_t(std::max(perTriangle, 0)));
    const glm::dmat3 linear(world_T_model);
    for (std::size_t t = 0; t < triangles; ++t) {
        const std::uint32_t i0 = mesh.indices[3 * t], i1 = mesh.indices[3 * t + 1], i2 = mesh.indices[3 * t + 2];
        for (int k = 0; k < perTriangle; ++k) {
            const std::uint32_t id = std::uint32_t(t) * std::uint32_t(perTriangle) + std::uint32_t(k);
            const double u1 = unitFromHash(pcgHash(seed ^ (2u * id)));
            const double u2 = unitFromHash(pcgHash(seed ^ (2u * id + 1u)));
            const double s = std::sqrt(u1);
            const double w0 = 1.0 - s, w1 = s * (1.0 - u2), w2 = s * u2;
            const glm::dvec3 p = w0 * glm::dvec3(mesh.positions[i0]) + w1 * glm::dvec3(mesh.positions[i1]) +
                                 w2 * glm::dvec3(mesh.positions[i2]);
            const glm::dvec3 n = w0 * glm::dvec3(mesh.normals[i0]) + w1 * glm::dvec3(mesh.normals[i1]) +
                                 w2 * glm::dvec3(mesh.normals[i2]);
            SurfacePoint point;
            point.position = glm::dvec3(world_T_model * glm::dvec4(p, 1.0));
            const glm::dvec3 wn = linear * n;
            point.normal = glm::length(wn) > 0.0 ? glm::normalize(wn) : glm::dvec3(0.0);
            point.albedo = albedo;
            out.push_back(point);
        }
    }
    return out;
}

glm::dvec3 directIrradiance(const glm::dvec3& position, const glm::dvec3& normal, std::span<const SceneLight> lights,
                            const LightVisibility& visible) {
    glm::dvec3 e(0.0);
    for (std::size_t i = 0; i < lights.size(); ++i) {
        const SceneLight& light = lights[i];
        const glm::dvec3 toLight = light.position - position;
        const double d2 = glm::dot(toLight, toLight);
        if (!(d2 > 0.0)) continue;
        const glm::dvec3 l = toLight / std::sqrt(d2);
        const double cosTheta = glm::dot(normal, l);
        if (cosTheta <= 0.0) continue;
        double cone = 1.0;
        if (light.cosOuter > -1.5) {
            const double t = std::clamp(
                (glm::dot(-l, light.direction) - light.cosOuter) / (light.cosInner - light.cosOuter), 0.0, 1.0);
            cone = t * t * (3.0 - 2.0 * t);
        }
        if (cone <= 0.0 || (visible && !visible(i, position))) continue;
        e += light.intensity * (cone * cosTheta / d2);
    }
    return e;
}

void addDirectLight(std::span<SurfacePoint> points, std::span<const SceneLight> lights,
                    const LightVisibility& visible) {
    for (SurfacePoint& p : points) {
        p.radiance = glm::length(p.normal) > 0.0
                         ? p.albedo / kPi * directIrradiance(p.position, p.normal, lights, visible)
                         : glm::dvec3(0.0);
        p.emits = true;
    }
}

Volume::Volume(const Grid& g)
    : grid(g)
    , count(g.voxelCount(), 0u)
    , emitterCount(g.voxelCount(), 0u)
    , normalSum(g.voxelCount())
    , radianceSum(g.voxelCount())
    , albedoSum(g.voxelCount()) {}

void Volume::inject(std::span<const SurfacePoint> points) {
    for (const SurfacePoint& p : points) {
        const glm::ivec3 v = grid.voxelOf(p.position);
        if (!grid.inside(v)) continue;
        const std::size_t i = grid.index(v);
        ++count[i];
        normalSum[i] += p.normal;
        albedoSum[i] += p.albedo;
        if (p.emits) {
            ++emitterCount[i];
            radianceSum[i] += p.radiance;
        }
    }
}

glm::dvec3 Volume::normal(std::size_t v) const {
    if (count[v] == 0) return glm::dvec3(0.0);
    const glm::dvec3 mean = normalSum[v] / double(count[v]);
    const double length = glm::length(mean);
    return length >= 0.5 ? mean / length : glm::dvec3(0.0);
}

glm::dvec3 Volume::radiance(std::size_t v) const {
    return emitterCount[v] > 0 ? radianceSum[v] / double(emitterCount[v]) : glm::dvec3(0.0);
}

glm::dvec3 Volume::albedo(std::size_t v) const {
    return count[v] > 0 ? albedoSum[v] / double(count[v]) : glm::dvec3(0.0);
}

RgbSh gatherVoxel(const Volume& volume, std::span<const glm::dvec3> exitant, const glm::ivec3& voxel,
                  std::span<const glm::dvec3> directions, const MarchSettings& march) {
    const Grid& g = volume.grid;
    const glm::dvec3 centre = g.centre(voxel);
    RgbSh out;
    for (const glm::dvec3& d : directions) {
        glm::dvec3 radiance(0.0);
        bool hit = false;
        // Section 3.3: skip the voxel's bounding sphere (sqrt(3)/2 s), then one-voxel steps.
        for (double t = 0.5 * std::sqrt(3.0) * g.voxelSize; t <= march.maxDistance; t += g.voxelSize) {
            const glm::ivec3 v = g.voxelOf(centre + t * d);
            if (!g.inside(v)) break;
            const std::size_t i = g.index(v);
            if (!volume.occupied(i)) continue;
            hit = true;
            // Seen from the front only, unless the voxel's normals cancel (seen from every side).
            const glm::dvec3 n = volume.normal(i);
            if (!march.visibility && (glm::dot(d, n) < 0.0 || glm::dot(n, n) == 0.0)) radiance = exitant[i];
            break;
        }
        if (march.visibility) radiance = glm::dvec3(hit ? 0.0 : 1.0);
        const Sh4 y = shBasis(d);
        for (int c = 0; c < 3; ++c)
            for (std::size_t k = 0; k < 4; ++k) out.channel[std::size_t(c)][k] += radiance[c] * y[k];
    }
    const double weight = 4.0 * kPi / double(directions.size());
    for (Sh4& channel : out.channel)
        for (double& c : channel) c *= weight;
    return out;
}

glm::dvec3 reconstructIrradiance(const Volume& volume, std::span<const RgbSh> incoming, const glm::dvec3& position,
                                 const glm::dvec3& normal) {
    const Grid& g = volume.grid;
    const glm::dvec3 shifted = position + 0.5 * g.voxelSize * normal;
    // The eight voxel centres around p' (the trilinear cell): floor(q - 1/2) in voxel units.
    const glm::dvec3 q = (shifted - g.origin) / g.voxelSize - 0.5;
    const glm::ivec3 base(int(std::floor(q.x)), int(std::floor(q.y)), int(std::floor(q.z)));
    RgbSh free{}, occupied{};
    double freeWeight = 0.0, occupiedWeight = 0.0;
    for (int corner = 0; corner < 8; ++corner) {
        const glm::ivec3 v = base + glm::ivec3(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
        if (!g.inside(v)) continue;
        const glm::dvec3 toCentre = g.centre(v) - shifted;
        const double length = glm::length(toCentre);
        // Eq. 5: clamped cosine; a centre at p' itself faces every normal.
        const double w = length > 1e-12 * g.voxelSize ? std::max(0.0, glm::dot(normal, toCentre) / length) : 1.0;
        if (w <= 0.0) continue;
        const std::size_t i = g.index(v);
        RgbSh& sum = volume.occupied(i) ? occupied : free;
        (volume.occupied(i) ? occupiedWeight : freeWeight) += w;
        for (std::size_t c = 0; c < 3; ++c)
            for (std::size_t k = 0; k < 4; ++k) sum.channel[c][k] += w * incoming[i].channel[c][k];
    }
    const RgbSh& chosen = freeWeight > 0.0 ? free : occupied;
    const double total = freeWeight > 0.0 ? freeWeight : occupiedWeight;
    if (total <= 0.0) return glm::dvec3(0.0);
    glm::dvec3 e;
    for (int c = 0; c < 3; ++c) e[c] = std::max(0.0, shIrradiance(chosen.channel[std::size_t(c)], normal) / total);
    return e;
}

std::vector<RgbSh> solve(const Volume& volume, std::span<const glm::dvec3> directions, int bounces,
                         const MarchSettings& march) {
    LIGHTSKIN_ASSERT(bounces >= 1, "lightskin::gi::reference::volumes::solve(): bounces must be >= 1");
    const Grid& g = volume.grid;
    const std::size_t n = g.voxelCount();
    std::vector<glm::dvec3> exitant(n);
    for (std::size_t i = 0; i < n; ++i) exitant[i] = volume.radiance(i);
    std::vector<RgbSh> incoming(n);
    const int passes = march.visibility ? 1 : bounces;
    for (int pass = 0; pass < passes; ++pass) {
        if (pass > 0) {
            for (std::size_t i = 0; i < n; ++i) {
                if (!volume.occupied(i)) continue;
                const glm::dvec3 normal = volume.normal(i);
                exitant[i] = volume.radiance(i);
                if (glm::dot(normal, normal) == 0.0) continue;
                const std::size_t r = std::size_t(g.resolution);
                const glm::ivec3 v(int(i % r), int((i / r) % r), int(i / (r * r)));
                exitant[i] += volume.albedo(i) / kPi * reconstructIrradiance(volume, incoming, g.centre(v), normal);
            }
        }
        for (int z = 0; z < g.resolution; ++z)
            for (int y = 0; y < g.resolution; ++y)
                for (int x = 0; x < g.resolution; ++x) {
                    const glm::ivec3 v(x, y, z);
                    incoming[g.index(v)] = gatherVoxel(volume, exitant, v, directions, march);
                }
    }
    return incoming;
}

} // namespace lightskin::gi::reference::volumes
