#include "lightskin/src/cpu/CpuGatherKernels.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/differential/DifferentialIrradiance.h>
#include <lightskin/gi/common/TriangleRayScene.h>

#include <epoxy/gl.h>
#include <glm/geometric.hpp>
#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

namespace lightskin::gi {

namespace {

/// One emitter's place on its object: triangle and the square-root map's coordinates (su = sqrt(u), r).
struct EmitterSite {
    std::size_t instance = 0;
    std::size_t triangle = 0;
    double su = 0.0, r = 0.0;
    double areaShare = 0.0; ///< of the object's surface area: 1 / emittersPerObject
};

struct BoundingSphere {
    glm::dvec3 centre{0.0};
    double radius = 0.0;
    double regionRadius = 0.0; ///< R_o (header: falloff)
};

/// The closed segment a-b passes within r of c.
bool segmentNearSphere(const glm::dvec3& a, const glm::dvec3& b, const BoundingSphere& s) {
    const glm::dvec3 d = b - a;
    const double length2 = glm::dot(d, d);
    const double t = length2 > 0.0 ? std::clamp(glm::dot(s.centre - a, d) / length2, 0.0, 1.0) : 0.0;
    const glm::dvec3 nearest = a + t * d - s.centre;
    return glm::dot(nearest, nearest) <= s.radius * s.radius;
}

/// Van der Corput radical inverse in base 2 (the second coordinate of a Hammersley set).
double radicalInverse2(std::uint32_t bits) {
    bits = (bits << 16u) | (bits >> 16u);
    bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
    bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
    bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
    bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
    return double(bits) * 2.3283064365386963e-10;
}

glm::dvec3 toDouble(const glm::vec3& v) { return glm::dvec3(v); }

/// A rotation (or mirroring) times one uniform scale, up to float rounding of a composed transform.
bool keepsAreaRatios(const glm::dmat3& a) {
    const double s = (glm::length(a[0]) + glm::length(a[1]) + glm::length(a[2])) / 3.0;
    constexpr double kTolerance = 1e-4;
    return s > 0.0 && std::abs(glm::length(a[0]) - s) <= kTolerance * s &&
           std::abs(glm::length(a[1]) - s) <= kTolerance * s && std::abs(glm::length(a[2]) - s) <= kTolerance * s &&
           std::abs(glm::dot(a[0], a[1])) <= kTolerance * s * s &&
           std::abs(glm::dot(a[0], a[2])) <= kTolerance * s * s && std::abs(glm::dot(a[1], a[2])) <= kTolerance * s * s;
}

/// Direct irradiance I cone cos / d^2 of a light at (x, n), without visibility; 0 behind.
glm::dvec3 lightIrradiance(const glm::dvec3& x, const glm::dvec3& n, const VirtualLight& light) {
    const glm::dvec3 offset = toDouble(light.position) - x;
    const double d2 = glm::dot(offset, offset);
    if (!(d2 > 0.0)) return glm::dvec3(0.0);
    const glm::dvec3 l = offset / std::sqrt(d2);
    const double cosTheta = glm::dot(n, l);
    if (!(cosTheta > 0.0)) return glm::dvec3(0.0);
    if (light.type == VirtualLight::Type::Spot &&
        glm::dot(-l, glm::normalize(toDouble(light.direction))) < std::cos(double(light.spotHalfAngle)))
        return glm::dvec3(0.0);
    return toDouble(light.intensity) * (cosTheta / d2);
}

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

/// The valid VALs as structure-of-arrays floats (flux unscaled, r2 = area / pi), for the shadow tests.
struct DiscArrays {
    std::vector<float> px, py, pz, nx, ny, nz, r2, fr, fg, fb;
};

/// VALs per leaf cluster and leaf clusters per group of the indirect-shadow cull (two levels: a
/// receiver tests ~n/256 groups, then 16 blocks of each group its segments can reach, then their VALs).
constexpr std::uint32_t kBlockVals = 16;
constexpr std::uint32_t kGroupBlocks = 16;
/// VALs per summation tile of the SIMD gather (as CpuLightSkin: a tile and a receiver group sit in L1).
constexpr std::uint32_t kValTile = 2048;

/// A receiver's side of the block test: its position and normal in float, and per object sphere
/// (centre - x, r^2) as 4 floats.
struct BlockQuery {
    float x, y, z, nx, ny, nz;
    const float* spheres;
    std::size_t sphereCount;
};

/// w_j and the candidate mark (1: w_j > 0 and the segment passes some sphere whose bit min(k, 63) is
/// set in sphereMask; the others cannot be reached from the block) of the kBlockVals discs
/// from `first` (the arrays are padded to whole blocks with zero discs: w = 0, never a candidate). The
/// per-pair loop's formulas before the clusters, in float: w_j of eq. 3/4 with the guards G1/G2 of
/// ls_irradiance (E_j = flux_j w_j), and the segment's nearest point to the sphere's centre.
/// Fixed length, branch-free: the compiler vectorises it.
void testBlock(const DiscArrays& d, std::uint32_t first, const BlockQuery& q, std::uint64_t sphereMask, float* wOut,
               float* nearOut) {
    // Local arrays and local copies of the disc pointers: the compiler sees that nothing aliases, and
    // vectorises the fixed-length loops (through the output pointers it kept them scalar).
    const float *px = d.px.data() + first, *py = d.py.data() + first, *pz = d.pz.data() + first;
    const float *nx = d.nx.data() + first, *ny = d.ny.data() + first, *nz = d.nz.data() + first;
    const float* r2 = d.r2.data() + first;
    const float invPi = float(1.0 / std::numbers::pi);
    std::array<float, kBlockVals> w, near, dx, dy, dz;
    for (std::uint32_t m = 0; m < kBlockVals; ++m) { // w_j
        dx[m] = px[m] - q.x;
        dy[m] = py[m] - q.y;
        dz[m] = pz[m] - q.z;
        const float d2 = dx[m] * dx[m] + dy[m] * dy[m] + dz[m] * dz[m];
        const float inv = 1.0f / std::sqrt(std::max(d2 + 1.0e-12f * r2[m], 1.0e-36f)); // G1
        const float cosI = std::max((q.nx * dx[m] + q.ny * dy[m] + q.nz * dz[m]) * inv, 0.0f);
        const float cosJ = std::max(-(nx[m] * dx[m] + ny[m] * dy[m] + nz[m] * dz[m]) * inv, 0.0f);
        w[m] = cosJ / std::max(r2[m] + d2, 1.0e-36f) * cosI * invPi; // G2
        near[m] = 0.0f;
    }
    for (std::size_t k = 0; k < q.sphereCount; ++k) { // the segment test, against the reachable spheres
        if (((sphereMask >> std::min<std::size_t>(k, 63)) & 1u) == 0) continue;
        const float cx = q.spheres[4 * k], cy = q.spheres[4 * k + 1], cz = q.spheres[4 * k + 2],
                    radius2 = q.spheres[4 * k + 3];
        for (std::uint32_t m = 0; m < kBlockVals; ++m) {
            const float length2 = std::max(dx[m] * dx[m] + dy[m] * dy[m] + dz[m] * dz[m], 1.0e-36f);
            const float t = std::clamp((cx * dx[m] + cy * dy[m] + cz * dz[m]) / length2, 0.0f, 1.0f);
            const float ex = t * dx[m] - cx, ey = t * dy[m] - cy, ez = t * dz[m] - cz;
            near[m] = (ex * ex + ey * ey + ez * ez <= radius2) & (w[m] > 0.0f) ? 1.0f : near[m]; // no short-circuit
        }
    }
    std::copy(w.begin(), w.end(), wOut);
    std::copy(near.begin(), near.end(), nearOut);
}

/// Squared distance from c to the closed segment a-b (double).
double segmentDistance2(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    const glm::dvec3 d = b - a;
    const double length2 = glm::dot(d, d);
    const double t = length2 > 0.0 ? std::clamp(glm::dot(c - a, d) / length2, 0.0, 1.0) : 0.0;
    const glm::dvec3 q = a + t * d - c;
    return glm::dot(q, q);
}

/// 10-bit Morton interleave (x in [0, 1023]) for the VALs' spatial order.
std::uint32_t spreadBits10(std::uint32_t v) {
    v &= 0x3FFu;
    v = (v | (v << 16u)) & 0x030000FFu;
    v = (v | (v << 8u)) & 0x0300F00Fu;
    v = (v | (v << 4u)) & 0x030C30C3u;
    v = (v | (v << 2u)) & 0x09249249u;
    return v;
}

/// A cluster of consecutive VALs of the spatial order: its members lie in the ball (centre, radius).
struct ValBall {
    glm::dvec3 centre{0.0};
    double radius = 0.0;
    std::uint32_t begin = 0, end = 0; ///< slots [begin, end) of the sorted VALs (blocks) or blocks (groups)
};

} // namespace

void validate(const DifferentialSettings& s) {
    const auto fail = [](const std::string& field, const std::string& expected) {
        throw Error("DifferentialSettings", std::nullopt, field + ": expected " + expected);
    };
    if (s.receiverStride < 1 || s.receiverStride > 64) fail("receiverStride", "1..64");
    if (!(s.falloffFraction > 0.0f && s.falloffFraction < 1.0f)) fail("falloffFraction", "a value in (0, 1)");
    if (s.emittersPerObject < 0 || s.emittersPerObject > 65536) fail("emittersPerObject", "0..65536");
    if (s.normalWindowRadius < 1 || s.normalWindowRadius > 16) fail("normalWindowRadius", "1..16");
    if (!(s.maxDepthChange > 0.0f)) fail("maxDepthChange", "> 0");
    if (!(s.minDepth >= 0.0f && s.maxDepth > s.minDepth)) fail("minDepth/maxDepth", "0 <= minDepth < maxDepth");
    if (!(s.rayEpsilon > 0.0 && s.rayEpsilon < 0.5)) fail("rayEpsilon", "a value in (0, 0.5)");
}

struct DifferentialIrradiance::Impl {
    DifferentialSettings settings;
    TriangleRayScene scene; ///< the virtual meshes, world frame
    std::vector<BoundingSphere> spheres;
    std::vector<const TriangleMesh*> meshes; ///< the instances' meshes, as create() got them
    /// Emitter sites in model space, fixed at create(); place() makes them world emitters.
    std::vector<EmitterSite> sites;
    std::vector<double> objectArea;        ///< world surface area per instance (place())
    std::vector<glm::dvec3> world;         ///< place()'s world vertices, instance after instance
    std::vector<std::size_t> worldOffsets; ///< first vertex of each instance in `world`
    std::vector<RayMesh> rayMeshes;        ///< place()'s placements for the ray scene
    // Emitters: geometry set by place(), flux per frame.
    std::vector<glm::dvec3> emitterPosition, emitterNormal, emitterAlbedo;
    std::vector<double> emitterArea;
    std::vector<VirtualAreaLight> emitters;
    // Per frame, sized on the first frames and reused (vectors keep their capacity):
    DiscArrays valArrays;               ///< the valid VALs in spatial (Morton) order, for the shadow tests
    std::vector<std::uint64_t> valKeys; ///< sort scratch: Morton code << 32 | input index
    std::vector<ValBall> valBlocks, valGroups;
    cpu::ValArrays valSimd, emitterSimd;  ///< the SIMD gather's VALs (sorted) and emitter discs
    cpu::ReceiverArrays gatherReceivers;  ///< receivers in the region (then emitters) for the SIMD gather
    cpu::ReceiverArrays emitterReceivers; ///< the emitters as receivers of the VALs
    cpu::ReceiverArrays noReceivers;      ///< prepareGather's block boxes of the emitter discs alone
    std::vector<float> valSums, emitterSums, emitterValSums; ///< kGatherSums x padded receivers each
    std::vector<std::uint32_t> regionReceivers;              ///< grid index of each receiver in the region, grid order
    std::vector<DifferentialReceiver> receivers;
    int gridWidth = 0, gridHeight = 0;

    bool occluded(const glm::dvec3& from, const glm::dvec3& to) const {
        // unnormalised direction: t in [eps, 1 - eps] is the segment at any scale
        return scene.occluded(from, to - from, settings.rayEpsilon, 1.0 - settings.rayEpsilon);
    }

    /// Segment x-y blocked by a virtual mesh; the bounding spheres decide most segments without a ray.
    bool blocked(const glm::dvec3& x, const glm::dvec3& y, std::int64_t& rays) const {
        for (const BoundingSphere& s : spheres)
            if (segmentNearSphere(x, y, s)) {
                ++rays;
                return occluded(x, y);
            }
        return false;
    }

    /// The valid VALs in Morton order (valArrays, valSimd) and their clusters.
    void sortVals(std::span<const VirtualAreaLight> vals);
    /// Sums of `discs` (SIMD, eq. 3/4) at `receivers` [0, count) into sums (kGatherSums x padded).
    void gatherSimd(const cpu::ValArrays& discs, const cpu::ReceiverArrays& at, std::vector<float>& sums) const;
    /// Emitter flux of this frame from the VALs (sorted first) and the lights.
    void updateEmitters(std::span<const DifferentialLightSource> lights, std::int64_t& rays);
    /// Receiver (i, j): position, normal, validity and whether it is in the region (no gathering).
    void placeReceiver(const cv::Mat& depth, const CameraIntrinsics& k, const Pose& world_T_camera, int i, int j,
                       std::span<const DifferentialLightSource> lights, DifferentialReceiver& r) const;
    /// dE and E_without of a receiver in the region; vals: the SIMD sums of the VALs (E_j summed),
    /// bounce: of the emitters.
    void gatherReceiver(const cv::Mat& depth, const CameraIntrinsics& k, const Pose& camera_T_world,
                        std::span<const DifferentialLightSource> lights, const glm::dvec3& valsIrradiance,
                        const glm::dvec3& bounce, DifferentialReceiver& r, std::int64_t& rays) const;
    void interpolate(const cv::Mat& depth, DifferentialImages& out) const;
};

DifferentialIrradiance::DifferentialIrradiance() = default;
DifferentialIrradiance::~DifferentialIrradiance() = default;
DifferentialIrradiance::DifferentialIrradiance(DifferentialIrradiance&&) noexcept = default;
DifferentialIrradiance& DifferentialIrradiance::operator=(DifferentialIrradiance&&) noexcept = default;

DifferentialIrradiance DifferentialIrradiance::create(std::span<const MeshInstance> instances,
                                                      const DifferentialSettings& settings) {
    validate(settings);
    DifferentialIrradiance out;
    out.impl_ = std::make_unique<Impl>();
    Impl& impl = *out.impl_;
    impl.settings = settings;
    // Emitter sites: N stratified points along the area CDF of each object (first coordinate), the radical
    // inverse across each triangle (second), uniform in the triangle by the square-root map. A rotation times a
    // uniform scale keeps area ratios: then the CDF is taken in model space, so the sites are the same bits
    // wherever the object is placed (created there or moved there by place()); otherwise as placed now.
    std::vector<double> cumulative;
    std::vector<glm::dvec3> world;
    for (std::size_t m = 0; m < instances.size(); ++m) {
        LIGHTSKIN_ASSERT(instances[m].mesh != nullptr,
                         "lightskin::gi::DifferentialIrradiance::create(): instance without a CPU mesh");
        const TriangleMesh& mesh = *instances[m].mesh;
        mesh.validate("differential: virtual object " + std::to_string(m));
        impl.meshes.push_back(&mesh);
        if (mesh.triangleCount() == 0) continue;
        const glm::dmat4 world_T_model(instances[m].world_T_model);
        const glm::dmat4 cdfFrame = keepsAreaRatios(glm::dmat3(world_T_model)) ? glm::dmat4(1.0) : world_T_model;
        world.resize(mesh.vertexCount());
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v)
            world[v] = glm::dvec3(cdfFrame * glm::dvec4(toDouble(mesh.positions[v]), 1.0));
        cumulative.assign(mesh.triangleCount(), 0.0);
        double total = 0.0;
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
            const glm::dvec3 &a = world[mesh.indices[3 * t]], &b = world[mesh.indices[3 * t + 1]],
                             &c = world[mesh.indices[3 * t + 2]];
            total += 0.5 * glm::length(glm::cross(b - a, c - a));
            cumulative[t] = total;
        }
        if (!(total > 0.0)) continue;
        const std::size_t n = std::size_t(settings.emittersPerObject);
        for (std::size_t e = 0; e < n; ++e) {
            const double target = (double(e) + 0.5) / double(n) * total;
            const std::size_t t =
                std::size_t(std::lower_bound(cumulative.begin(), cumulative.end(), target) - cumulative.begin());
            const std::size_t tri = std::min(t, mesh.triangleCount() - 1);
            const double before = tri == 0 ? 0.0 : cumulative[tri - 1];
            const double area = cumulative[tri] - before;
            const double u = area > 0.0 ? std::clamp((target - before) / area, 0.0, 1.0) : 0.5;
            impl.sites.push_back({m, tri, std::sqrt(u), radicalInverse2(std::uint32_t(e)), 1.0 / double(n)});
        }
    }
    std::vector<RayMesh> rayMeshes;
    for (const MeshInstance& instance : instances)
        rayMeshes.push_back({instance.mesh, glm::dmat4(instance.world_T_model)});
    impl.scene = TriangleRayScene::create(rayMeshes, "differential");
    out.place(instances);
    impl.noReceivers.resize(0);
    return out;
}

void DifferentialIrradiance::place(std::span<const MeshInstance> instances) {
    Impl& impl = *impl_;
    LIGHTSKIN_ASSERT(instances.size() == impl.meshes.size(), "DifferentialIrradiance::place(): other instances");
    const double regionFactor = std::sqrt(1.0 / double(impl.settings.falloffFraction) - 1.0);
    impl.spheres.clear();
    impl.objectArea.assign(instances.size(), 0.0);
    impl.worldOffsets.assign(instances.size() + 1, 0);
    std::size_t vertices = 0;
    for (std::size_t m = 0; m < instances.size(); ++m) {
        impl.worldOffsets[m] = vertices;
        vertices += impl.meshes[m]->vertexCount();
    }
    impl.worldOffsets[instances.size()] = vertices;
    impl.world.resize(vertices);
    impl.rayMeshes.clear();
    for (std::size_t m = 0; m < instances.size(); ++m) {
        LIGHTSKIN_ASSERT(instances[m].mesh == impl.meshes[m], "DifferentialIrradiance::place(): other meshes");
        const TriangleMesh& mesh = *impl.meshes[m];
        const glm::dmat4 world_T_model(instances[m].world_T_model);
        impl.rayMeshes.push_back({&mesh, world_T_model});
        if (mesh.triangleCount() == 0) continue;
        glm::dvec3* world = impl.world.data() + impl.worldOffsets[m];
        glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
            world[v] = glm::dvec3(world_T_model * glm::dvec4(toDouble(mesh.positions[v]), 1.0));
            lo = glm::min(lo, world[v]);
            hi = glm::max(hi, world[v]);
        }
        BoundingSphere sphere;
        sphere.centre = 0.5 * (lo + hi);
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v)
            sphere.radius = std::max(sphere.radius, glm::length(world[v] - sphere.centre));
        sphere.radius *= 1.0 + 1e-6; // float vertices exactly on the sphere stay inside
        sphere.regionRadius = sphere.radius * regionFactor;
        impl.spheres.push_back(sphere);
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
            const glm::dvec3 &a = world[mesh.indices[3 * t]], &b = world[mesh.indices[3 * t + 1]],
                             &c = world[mesh.indices[3 * t + 2]];
            impl.objectArea[m] += 0.5 * glm::length(glm::cross(b - a, c - a));
        }
    }
    impl.emitterPosition.clear();
    impl.emitterNormal.clear();
    impl.emitterArea.clear();
    impl.emitterAlbedo.clear();
    for (const EmitterSite& site : impl.sites) {
        const TriangleMesh& mesh = *impl.meshes[site.instance];
        const glm::dvec3* world = impl.world.data() + impl.worldOffsets[site.instance];
        const glm::dvec3 &a = world[mesh.indices[3 * site.triangle]], &b = world[mesh.indices[3 * site.triangle + 1]],
                         &c = world[mesh.indices[3 * site.triangle + 2]];
        const glm::dvec3 normal = glm::cross(b - a, c - a);
        if (!(glm::length(normal) > 0.0)) continue;
        impl.emitterPosition.push_back(a * (1.0 - site.su) + b * (site.su * (1.0 - site.r)) + c * (site.su * site.r));
        impl.emitterNormal.push_back(glm::normalize(normal)); // counter-clockwise front faces (TriangleMesh)
        impl.emitterArea.push_back(impl.objectArea[site.instance] * site.areaShare);
        impl.emitterAlbedo.push_back(toDouble(instances[site.instance].material.diffuseAlbedo));
    }
    impl.scene.place(impl.rayMeshes, "differential");
    const std::size_t emitterCount = impl.emitterPosition.size();
    impl.emitters.resize(emitterCount);
    const std::size_t emitterPadded = (emitterCount + cpu::kSumBlock - 1) / cpu::kSumBlock * cpu::kSumBlock;
    impl.emitterSimd.reserve(std::max<std::size_t>(emitterPadded, cpu::kSumBlock));
}

namespace {

/// Slots [count, padded to kSumBlock) as zero-area, zero-flux discs: they add exactly +0.
void padSimdDiscs(cpu::ValArrays& simd, std::uint32_t count) {
    simd.count = count;
    simd.padded = (count + cpu::kSumBlock - 1) / cpu::kSumBlock * cpu::kSumBlock;
    for (std::uint32_t j = count; j < simd.padded; ++j) {
        for (auto* v : {&simd.px, &simd.py, &simd.pz, &simd.negNx, &simd.negNy, &simd.r2, &simd.cr2, &simd.fr, &simd.fg,
                        &simd.fb})
            (*v)[j] = 0.0f;
        simd.negNz[j] = -1.0f; // a unit normal (+z), stored negated
    }
}

/// Receiver slot n of the SIMD gather (the glossy inputs unused: finite dummies).
void setSimdReceiver(cpu::ReceiverArrays& r, std::size_t n, const glm::dvec3& x, const glm::dvec3& normal) {
    r.px[n] = float(x.x);
    r.py[n] = float(x.y);
    r.pz[n] = float(x.z);
    r.nx[n] = float(normal.x);
    r.ny[n] = float(normal.y);
    r.nz[n] = float(normal.z);
    r.ex[n] = r.nx[n];
    r.ey[n] = r.ny[n];
    r.ez[n] = r.nz[n];
    r.rx[n] = r.nx[n]; // the mirror of e = n about n: n
    r.ry[n] = r.ny[n];
    r.rz[n] = r.nz[n];
    r.k[n] = 1.0f;
    r.ck[n] = 0.0f;
}

bool validDisc(const VirtualAreaLight& d) {
    return d.area > 0.0f && std::isfinite(d.area) && finite(d.position) && finite(d.normal) && finite(d.flux);
}

} // namespace

void DifferentialIrradiance::Impl::sortVals(std::span<const VirtualAreaLight> vals) {
    // Morton order over the valid VALs' bounding box: consecutive VALs are near each other, so blocks of
    // them have small bounding balls (the shadow cull) and boxes (the SIMD gather's hidden-block skip).
    glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const VirtualAreaLight& v : vals)
        if (validDisc(v)) {
            lo = glm::min(lo, glm::dvec3(v.position));
            hi = glm::max(hi, glm::dvec3(v.position));
        }
    valKeys.clear(); // keeps capacity
    for (std::size_t i = 0; i < vals.size(); ++i) {
        if (!validDisc(vals[i])) continue; // adds exactly 0 (ls_irradiance), so it is left out
        std::uint32_t code = 0;
        for (int axis = 0; axis < 3; ++axis) {
            const double extent = hi[axis] - lo[axis];
            const double unit = extent > 0.0 ? (double(vals[i].position[axis]) - lo[axis]) / extent : 0.0;
            code |= spreadBits10(std::uint32_t(std::clamp(unit * 1023.0, 0.0, 1023.0))) << std::uint32_t(axis);
        }
        valKeys.push_back(std::uint64_t(code) << 32u | std::uint64_t(i)); // ties by input index: one order
    }
    std::sort(valKeys.begin(), valKeys.end());
    const std::size_t n = valKeys.size();
    for (auto* v : {&valArrays.px, &valArrays.py, &valArrays.pz, &valArrays.nx, &valArrays.ny, &valArrays.nz,
                    &valArrays.r2, &valArrays.fr, &valArrays.fg, &valArrays.fb})
        v->assign((n + kBlockVals - 1) / kBlockVals * kBlockVals, 0.0f); // zero discs pad the last block
    const std::size_t padded = (n + cpu::kSumBlock - 1) / cpu::kSumBlock * cpu::kSumBlock;
    if (valSimd.px.size() < padded) valSimd.reserve(padded); // grows only past the largest frame
    for (std::size_t s = 0; s < n; ++s) {
        const std::uint32_t i = std::uint32_t(valKeys[s] & 0xFFFFFFFFu);
        const VirtualAreaLight& d = vals[i];
        valArrays.px[s] = d.position.x;
        valArrays.py[s] = d.position.y;
        valArrays.pz[s] = d.position.z;
        valArrays.nx[s] = d.normal.x;
        valArrays.ny[s] = d.normal.y;
        valArrays.nz[s] = d.normal.z;
        valArrays.r2[s] = d.area / float(std::numbers::pi);
        valArrays.fr[s] = d.flux.x;
        valArrays.fg[s] = d.flux.y;
        valArrays.fb[s] = d.flux.z;
        cpu::setVal(valSimd, std::uint32_t(s), d);
    }
    padSimdDiscs(valSimd, std::uint32_t(n));

    // Bounding balls: blocks of kBlockVals sorted VALs, groups of kGroupBlocks blocks (centre of the
    // box, radius to the farthest member, computed from the float positions the member tests use).
    const auto ball = [](std::span<const glm::dvec3> points) {
        glm::dvec3 boxLo(std::numeric_limits<double>::infinity()), boxHi(-std::numeric_limits<double>::infinity());
        for (const glm::dvec3& p : points) boxLo = glm::min(boxLo, p), boxHi = glm::max(boxHi, p);
        ValBall b;
        b.centre = 0.5 * (boxLo + boxHi);
        for (const glm::dvec3& p : points) b.radius = std::max(b.radius, glm::length(p - b.centre));
        return b;
    };
    valBlocks.clear();
    for (std::size_t first = 0; first < n; first += kBlockVals) {
        const std::size_t last = std::min(first + kBlockVals, n);
        std::array<glm::dvec3, kBlockVals> points;
        for (std::size_t s = first; s < last; ++s)
            points[s - first] = glm::dvec3(valArrays.px[s], valArrays.py[s], valArrays.pz[s]);
        ValBall b = ball(std::span(points.data(), last - first));
        b.begin = std::uint32_t(first);
        b.end = std::uint32_t(last);
        valBlocks.push_back(b);
    }
    valGroups.clear();
    for (std::size_t first = 0; first < valBlocks.size(); first += kGroupBlocks) {
        const std::size_t last = std::min(first + kGroupBlocks, valBlocks.size());
        ValBall g;
        glm::dvec3 boxLo(std::numeric_limits<double>::infinity()), boxHi(-std::numeric_limits<double>::infinity());
        for (std::size_t b = first; b < last; ++b) {
            boxLo = glm::min(boxLo, valBlocks[b].centre - glm::dvec3(valBlocks[b].radius));
            boxHi = glm::max(boxHi, valBlocks[b].centre + glm::dvec3(valBlocks[b].radius));
        }
        g.centre = 0.5 * (boxLo + boxHi);
        for (std::size_t b = first; b < last; ++b) // the group's ball holds every block's ball
            g.radius = std::max(g.radius, glm::length(valBlocks[b].centre - g.centre) + valBlocks[b].radius);
        g.begin = std::uint32_t(first);
        g.end = std::uint32_t(last);
        valGroups.push_back(g);
    }
}

void DifferentialIrradiance::Impl::gatherSimd(const cpu::ValArrays& discs, const cpu::ReceiverArrays& at,
                                              std::vector<float>& sums) const {
    sums.assign(cpu::kGatherSums * at.padded, 0.0f); // keeps capacity
    if (discs.padded == 0 || at.padded == 0) return;
    const cpu::GatherParameters parameters{false, false, true}; // diffuse sums only; exact hidden-block skip
    const int groups = int(at.padded / cpu::kReceiverPadding);
    // Each receiver's sums run over the discs in their order whatever the split (CpuGatherKernels.h):
    // the result does not depend on the thread count.
    cv::parallel_for_(cv::Range(0, groups), [&](const cv::Range& range) {
        const std::size_t begin = std::size_t(range.start) * cpu::kReceiverPadding,
                          end = std::size_t(range.end) * cpu::kReceiverPadding;
        for (std::uint32_t first = 0; first < discs.padded; first += kValTile)
            cpu::gather(discs, first, std::min(first + kValTile, discs.padded), at, begin, end, parameters, sums.data(),
                        at.padded);
    });
}

void DifferentialIrradiance::Impl::updateEmitters(std::span<const DifferentialLightSource> lights, std::int64_t& rays) {
    // The emitters' irradiance from the room's VALs: the SIMD gather with the emitters as receivers.
    const std::size_t count = emitters.size();
    emitterReceivers.resize((count + cpu::kReceiverPadding - 1) / cpu::kReceiverPadding * cpu::kReceiverPadding);
    for (std::size_t k = 0; k < count; ++k) setSimdReceiver(emitterReceivers, k, emitterPosition[k], emitterNormal[k]);
    cpu::prepareGather(valSimd, emitterReceivers, count);
    gatherSimd(valSimd, emitterReceivers, emitterValSums);
    std::atomic<std::int64_t> rayCount{0};
    cv::parallel_for_(cv::Range(0, int(count)), [&](const cv::Range& range) {
        std::int64_t localRays = 0;
        for (int e = range.start; e < range.end; ++e) {
            const std::size_t k = std::size_t(e);
            const glm::dvec3 &x = emitterPosition[k], &n = emitterNormal[k];
            glm::dvec3 irradiance(0.0);
            for (const DifferentialLightSource& source : lights) {
                const glm::dvec3 direct = lightIrradiance(x, n, source.light);
                if (direct == glm::dvec3(0.0)) continue;
                ++localRays;
                if (!occluded(x, toDouble(source.light.position))) irradiance += direct;
            }
            const std::size_t stride = emitterReceivers.padded;
            irradiance += glm::dvec3(emitterValSums[0 * stride + k], emitterValSums[1 * stride + k],
                                     emitterValSums[2 * stride + k]);
            VirtualAreaLight& out = emitters[k];
            out.position = glm::vec3(x);
            out.normal = glm::vec3(n);
            out.area = float(emitterArea[k]);
            const glm::dvec3 flux =
                emitterAlbedo[k] * irradiance * emitterArea[k]; // Lambertian exitance rho E times area
            out.flux = finite(flux) ? glm::vec3(flux) : glm::vec3(0.0f);
        }
        rayCount += localRays;
    });
    rays += rayCount.load();
    // The emitter discs for the receivers' bounce (validDisc as for the VALs; the order is kept).
    std::uint32_t n = 0;
    for (const VirtualAreaLight& e : emitters)
        if (validDisc(e)) cpu::setVal(emitterSimd, n++, e);
    padSimdDiscs(emitterSimd, n);
    cpu::prepareGather(emitterSimd, noReceivers, 0); // the discs' block boxes only
}

/// Real geometry between a receiver and a light, from the depth frame alone (a screen-space
/// shadow ray): 48 samples along the segment (the first 2 cm skipped: the receiver's own surface);
/// a sample that projects onto a valid depth pixel and lies behind it by more than
/// max(2 cm, 3 % z) (the depth noise and the normal window's smoothing) but less than 0.5 m (real
/// objects are assumed no thinner than the camera can tell apart: a table top and its body, not a
/// sheet) is inside real matter, so the light does not reach the receiver.
bool reallyOccluded(const cv::Mat& depth, const CameraIntrinsics& k, const Pose& camera_T_world, const glm::dvec3& from,
                    const glm::dvec3& to) {
    constexpr int kSamples = 48;
    const double length = glm::length(to - from);
    if (!(length > 0.02)) return false;
    for (int step = 0; step < kSamples; ++step) {
        const double t = 0.02 / length + (1.0 - 0.02 / length) * (double(step) + 0.5) / kSamples;
        const glm::dvec3 c = camera_T_world.transformPoint(from + t * (to - from));
        if (c.z <= 0.05) continue;
        const double u = k.fx * c.x / c.z + k.cx, v = k.fy * c.y / c.z + k.cy;
        const long pu = std::lround(u), pv = std::lround(v);
        if (pu < 0 || pv < 0 || pu >= depth.cols || pv >= depth.rows) continue;
        const double real = double(depth.at<float>(int(pv), int(pu)));
        if (!(real > 0.0) || !std::isfinite(real)) continue;
        const double behind = c.z - real;
        if (behind > std::max(0.02, 0.03 * real) && behind < 0.5) return true;
    }
    return false;
}

void DifferentialIrradiance::Impl::placeReceiver(const cv::Mat& depth, const CameraIntrinsics& k,
                                                 const Pose& world_T_camera, int i, int j,
                                                 std::span<const DifferentialLightSource> lights,
                                                 DifferentialReceiver& r) const {
    r = DifferentialReceiver{};
    const int s = settings.receiverStride, R = settings.normalWindowRadius;
    const int cu = i * s + s / 2, cv = j * s + s / 2;
    if (cu - R < 0 || cv - R < 0 || cu + R >= depth.cols || cv + R >= depth.rows) return;
    const auto z = [&depth](int u, int v) { return depth.at<float>(v, u); };
    const auto valid = [this](float d) { return d > settings.minDepth && d <= settings.maxDepth; };
    const auto backProject = [&k](int u, int v, double d) {
        return glm::dvec3((double(u) - k.cx) * d / k.fx, (double(v) - k.cy) * d / k.fy, d);
    };
    const float zc = z(cu, cv);
    if (!valid(zc)) return;
    const float maxStep = settings.maxDepthChange * zc;
    // ValGenerator's edge test and AVERAGE_3D_GRADIENT normal (gi/common/shaders/val_from_depth.comp).
    const int arms[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    for (const auto& arm : arms) {
        float previous = zc;
        for (int step = 1; step <= R; ++step) {
            const float d = z(cu + arm[0] * step, cv + arm[1] * step);
            if (!valid(d) || std::abs(d - previous) > maxStep) return;
            previous = d;
        }
    }
    glm::dvec3 gx(0.0), gy(0.0);
    float prevL = z(cu - R, cv - R), prevR = z(cu + R, cv - R), prevT = z(cu - R, cv - R), prevB = z(cu - R, cv + R);
    for (int d = -R; d <= R; ++d) {
        const float zl = z(cu - R, cv + d), zr = z(cu + R, cv + d), zt = z(cu + d, cv - R), zb = z(cu + d, cv + R);
        if (!valid(zl) || !valid(zr) || !valid(zt) || !valid(zb)) return;
        if (std::abs(zl - prevL) > maxStep || std::abs(zr - prevR) > maxStep || std::abs(zt - prevT) > maxStep ||
            std::abs(zb - prevB) > maxStep)
            return;
        prevL = zl;
        prevR = zr;
        prevT = zt;
        prevB = zb;
        gx += backProject(cu + R, cv + d, zr) - backProject(cu - R, cv + d, zl);
        gy += backProject(cu + d, cv + R, zb) - backProject(cu + d, cv - R, zt);
    }
    glm::dvec3 n = glm::cross(gy, gx);
    const double length = glm::length(n);
    if (!(length > 0.0) || !std::isfinite(length)) return;
    n /= length;
    const glm::dvec3 p = backProject(cu, cv, zc);
    if (glm::dot(n, p) > 0.0) n = -n; // toward the camera
    r.position = world_T_camera.transformPoint(p);
    r.normal = glm::normalize(world_T_camera.transformDirection(n));
    r.depth = zc;
    r.valid = true;

    // Region (header): near an object, or an object's bounding sphere between it and a light.
    for (const BoundingSphere& sphere : spheres) {
        const glm::dvec3 offset = r.position - sphere.centre;
        r.inRegion = r.inRegion || glm::dot(offset, offset) <= sphere.regionRadius * sphere.regionRadius;
        for (const DifferentialLightSource& source : lights)
            r.inRegion = r.inRegion || segmentNearSphere(r.position, toDouble(source.light.position), sphere);
    }
}

void DifferentialIrradiance::Impl::gatherReceiver(const cv::Mat& depth, const CameraIntrinsics& k,
                                                  const Pose& camera_T_world,
                                                  std::span<const DifferentialLightSource> lights,
                                                  const glm::dvec3& valsIrradiance, const glm::dvec3& bounce,
                                                  DifferentialReceiver& r, std::int64_t& rays) const {
    const glm::dvec3 &x = r.position, &nx = r.normal;
    glm::dvec3 without = valsIrradiance, delta(0.0);

    // The indirect shadow: VALs whose segment from x passes an object's bounding sphere (and whose
    // w_j > 0) get an Embree ray. The pair test is the per-pair loop's (testBlock), but only inside
    // clusters that can hold such a VAL: a segment x-y with y in the ball (c_b, rho_b) stays within rho_b
    // of the segment x-c_b (its point at t is x + t (y - x), within t rho_b <= rho_b of x + t (c_b - x)),
    // so it can pass within r of the sphere's centre c only if the segment x-c_b passes within
    // r + rho_b of c. The margin 1e-4 m covers the float rounding of the pair test (positions < 100 m:
    // ulp <= 8e-6 m), so a cluster is skipped only if the pair test would fail for all its VALs.
    const float fx = float(x.x), fy = float(x.y), fz = float(x.z);
    const float fnx = float(nx.x), fny = float(nx.y), fnz = float(nx.z);
    constexpr double kMargin = 1.0e-4;
    // Bit min(k, 63) set: sphere k can be reached from the cluster (objects 63 and up share a bit).
    const auto reaches = [&](const ValBall& b, std::uint64_t among) {
        std::uint64_t mask = 0;
        for (std::size_t o = 0; o < spheres.size(); ++o) {
            const std::uint64_t bit = std::uint64_t(1) << std::min<std::size_t>(o, 63);
            if ((among & bit) == 0) continue;
            const double reach = spheres[o].radius + b.radius + kMargin;
            if (segmentDistance2(x, b.centre, spheres[o].centre) <= reach * reach) mask |= bit;
        }
        return mask;
    };
    thread_local std::vector<std::pair<std::uint32_t, float>> candidates; // (sorted slot, w_j): grows once
    thread_local std::vector<float> sphereData;                           // per sphere: centre - x, r^2
    candidates.clear();
    sphereData.clear();
    for (const BoundingSphere& sphere : spheres) // centre - x as the per-pair loop had it: float(c) - float(x)
        for (const float value : {float(sphere.centre.x) - fx, float(sphere.centre.y) - fy, float(sphere.centre.z) - fz,
                                  float(sphere.radius * sphere.radius)})
            sphereData.push_back(value);
    const BlockQuery query{fx, fy, fz, fnx, fny, fnz, sphereData.data(), spheres.size()};
    for (const ValBall& group : valGroups) {
        const std::uint64_t groupMask = reaches(group, ~std::uint64_t(0));
        if (groupMask == 0) continue;
        for (std::uint32_t b = group.begin; b < group.end; ++b) {
            const ValBall& block = valBlocks[b];
            const std::uint64_t blockMask = reaches(block, groupMask); // a block lies in its group's ball
            if (blockMask == 0) continue;
            std::array<float, kBlockVals> w, near;
            testBlock(valArrays, block.begin, query, blockMask, w.data(), near.data());
            for (std::uint32_t m = 0; m < kBlockVals; ++m)
                if (near[m] != 0.0f) candidates.emplace_back(block.begin + m, w[m]);
        }
    }
    // Summed in the VALs' spatial order (the per-pair loop used the input order: rounding only).
    for (const auto& [v, w] : candidates) {
        ++rays;
        if (occluded(x, glm::dvec3(valArrays.px[v], valArrays.py[v], valArrays.pz[v]))) // the indirect shadow
            delta -= glm::dvec3(valArrays.fr[v], valArrays.fg[v], valArrays.fb[v]) * double(w);
    }
    for (const DifferentialLightSource& source : lights) {
        const glm::dvec3 e = lightIrradiance(x, nx, source.light);
        if (e == glm::dvec3(0.0)) continue;
        if (reallyOccluded(depth, k, camera_T_world, x, toDouble(source.light.position))) continue; // in neither image
        const bool shadowed = blocked(x, toDouble(source.light.position), rays);
        if (source.inRoom) {
            without += e;
            if (shadowed) delta -= e;
        } else if (!shadowed) {
            delta += e;
        }
    }
    delta += bounce; // the light the objects reflect
    r.irradianceWithout = finite(without) ? without : glm::dvec3(0.0);
    r.deltaIrradiance = finite(delta) ? delta : glm::dvec3(0.0);
}

void DifferentialIrradiance::Impl::interpolate(const cv::Mat& depth, DifferentialImages& out) const {
    const int s = settings.receiverStride;
    const float relative = settings.maxDepthChange;
    cv::parallel_for_(cv::Range(0, depth.rows), [&](const cv::Range& range) {
        for (int v = range.start; v < range.end; ++v) {
            auto* delta = out.deltaIrradiance.ptr<cv::Vec3f>(v);
            auto* without = out.irradianceWithout.ptr<cv::Vec3f>(v);
            auto* affected = out.affected.ptr<std::uint8_t>(v);
            const float* zRow = depth.ptr<float>(v);
            // Grid node j sits at pixel row j s + s/2.
            const double gy = (double(v) - double(s / 2)) / double(s);
            const int j0 = int(std::floor(gy));
            const double fy = gy - double(j0);
            for (int u = 0; u < depth.cols; ++u) {
                const float zp = zRow[u];
                if (!(zp > settings.minDepth && zp <= settings.maxDepth)) continue;
                const double gx = (double(u) - double(s / 2)) / double(s);
                const int i0 = int(std::floor(gx));
                const double fx = gx - double(i0);
                double weightSum = 0.0;
                glm::dvec3 d(0.0), w(0.0);
                for (int dj = 0; dj < 2; ++dj)
                    for (int di = 0; di < 2; ++di) {
                        const int i = i0 + di, j = j0 + dj;
                        if (i < 0 || j < 0 || i >= gridWidth || j >= gridHeight) continue;
                        const DifferentialReceiver& r =
                            receivers[std::size_t(j) * std::size_t(gridWidth) + std::size_t(i)];
                        if (!r.inRegion) continue;
                        const int distance = std::max(std::abs(u - (i * s + s / 2)), std::abs(v - (j * s + s / 2)));
                        if (std::abs(r.depth - zp) > relative * zp * float(std::max(1, distance)))
                            continue; // another surface
                        const double weight = (di == 0 ? 1.0 - fx : fx) * (dj == 0 ? 1.0 - fy : fy);
                        if (!(weight > 0.0)) continue;
                        weightSum += weight;
                        d += weight * r.deltaIrradiance;
                        w += weight * r.irradianceWithout;
                    }
                if (!(weightSum > 0.0)) continue;
                d /= weightSum;
                w /= weightSum;
                delta[u] = cv::Vec3f(float(d.z), float(d.y), float(d.x)); // RGB -> BGR
                without[u] = cv::Vec3f(float(w.z), float(w.y), float(w.x));
                affected[u] = 255;
            }
        }
    });
}

void DifferentialIrradiance::compute(const cv::Mat& depthMetres, const CameraIntrinsics& intrinsics,
                                     const Pose& world_T_camera, std::span<const VirtualAreaLight> vals,
                                     std::span<const DifferentialLightSource> lights, DifferentialImages& out) {
    LIGHTSKIN_ASSERT(impl_, "lightskin::gi::DifferentialIrradiance::compute(): used before create()");
    LIGHTSKIN_ASSERT(depthMetres.type() == CV_32FC1,
                     "lightskin::gi::DifferentialIrradiance::compute(): depth must be CV_32FC1 metres");
    Impl& impl = *impl_;
    const int s = impl.settings.receiverStride;
    impl.gridWidth = depthMetres.cols / s;
    impl.gridHeight = depthMetres.rows / s;
    impl.receivers.resize(std::size_t(impl.gridWidth) * std::size_t(impl.gridHeight));
    out.deltaIrradiance.create(depthMetres.size(), CV_32FC3);
    out.irradianceWithout.create(depthMetres.size(), CV_32FC3);
    out.affected.create(depthMetres.size(), CV_8UC1);
    out.deltaIrradiance.setTo(cv::Scalar::all(0));
    out.irradianceWithout.setTo(cv::Scalar::all(0));
    out.affected.setTo(cv::Scalar::all(0));
    out.receiversGathered = 0;
    out.shadowRays = 0;

    impl.sortVals(vals);
    impl.updateEmitters(lights, out.shadowRays);
    const Pose camera_T_world = world_T_camera.inverse();

    // 1. Every receiver's geometry and whether it is in the region (rows in parallel).
    cv::parallel_for_(cv::Range(0, impl.gridHeight), [&](const cv::Range& range) {
        for (int j = range.start; j < range.end; ++j)
            for (int i = 0; i < impl.gridWidth; ++i)
                impl.placeReceiver(depthMetres, intrinsics, world_T_camera, i, j, lights,
                                   impl.receivers[std::size_t(j) * std::size_t(impl.gridWidth) + std::size_t(i)]);
    });
    // 2. The region's receivers, in grid order, gather the VALs (E_without's sum) and the emitter discs
    // (the bounce) with CpuLightSkin's SIMD kernel: eq. 3/4 as before, in float sums of 16 discs.
    impl.regionReceivers.clear();
    for (std::size_t g = 0; g < impl.receivers.size(); ++g)
        if (impl.receivers[g].inRegion) impl.regionReceivers.push_back(std::uint32_t(g));
    const std::size_t count = impl.regionReceivers.size();
    impl.gatherReceivers.resize((count + cpu::kReceiverPadding - 1) / cpu::kReceiverPadding * cpu::kReceiverPadding);
    for (std::size_t n = 0; n < count; ++n) {
        const DifferentialReceiver& r = impl.receivers[impl.regionReceivers[n]];
        setSimdReceiver(impl.gatherReceivers, n, r.position, r.normal);
    }
    cpu::prepareGather(impl.valSimd, impl.gatherReceivers, count); // coherent receiver groups, VAL block boxes
    impl.gatherSimd(impl.valSimd, impl.gatherReceivers, impl.valSums);
    impl.gatherSimd(impl.emitterSimd, impl.gatherReceivers, impl.emitterSums);
    // 3. Per receiver: the indirect shadow (Embree), the lights, dE and E_without.
    const std::size_t stride = impl.gatherReceivers.padded;
    const auto sum = [stride](const std::vector<float>& sums, std::size_t n) {
        return glm::dvec3(sums[0 * stride + n], sums[1 * stride + n], sums[2 * stride + n]);
    };
    std::atomic<std::int64_t> rays{0};
    cv::parallel_for_(cv::Range(0, int(count)), [&](const cv::Range& range) {
        std::int64_t localRays = 0;
        for (int n = range.start; n < range.end; ++n) {
            const std::size_t at = std::size_t(n);
            impl.gatherReceiver(depthMetres, intrinsics, camera_T_world, lights, sum(impl.valSums, at),
                                sum(impl.emitterSums, at), impl.receivers[impl.regionReceivers[at]], localRays);
        }
        rays += localRays;
    });
    out.shadowRays += rays.load();
    out.receiversGathered = std::int64_t(count);
    impl.interpolate(depthMetres, out);
}

std::span<const DifferentialReceiver> DifferentialIrradiance::receivers() const noexcept { return impl_->receivers; }
int DifferentialIrradiance::gridWidth() const noexcept { return impl_->gridWidth; }
int DifferentialIrradiance::gridHeight() const noexcept { return impl_->gridHeight; }
std::span<const VirtualAreaLight> DifferentialIrradiance::emitters() const noexcept { return impl_->emitters; }
const DifferentialSettings& DifferentialIrradiance::settings() const noexcept { return impl_->settings; }

void downloadValsInto(const ValSetView& set, std::vector<VirtualAreaLight>& out) {
    out.resize(set.count);
    if (set.count == 0) return;
    glGetNamedBufferSubData(set.buffer, 0, GLsizeiptr(sizeof(VirtualAreaLight) * set.count), out.data());
}

} // namespace lightskin::gi
