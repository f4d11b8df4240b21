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

class CellCorners;

/// A square of (size + 1)^2 receivers from grid node (i, j) (it may stick out of the grid).
struct AdaptiveCell {
    int i = 0, j = 0, size = 1;
};

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
    if (s.receiverStride < 0 || s.receiverStride > 64) fail("receiverStride", "0 (automatic) or 1..64");
    if (!(s.falloffFraction > 0.0f && s.falloffFraction < 1.0f)) fail("falloffFraction", "a value in (0, 1)");
    if (s.emittersPerObject < 0 || s.emittersPerObject > 65536) fail("emittersPerObject", "0..65536");
    if (s.normalWindowRadius < 1 || s.normalWindowRadius > 16) fail("normalWindowRadius", "1..16");
    if (!(s.maxDepthChange > 0.0f)) fail("maxDepthChange", "> 0");
    if (!(s.minDepth >= 0.0f && s.maxDepth > s.minDepth)) fail("minDepth/maxDepth", "0 <= minDepth < maxDepth");
    if (!(s.rayEpsilon > 0.0 && s.rayEpsilon < 0.5)) fail("rayEpsilon", "a value in (0, 0.5)");
    if (s.refineCell < 1 || s.refineCell > 64 || (s.refineCell & (s.refineCell - 1)) != 0)
        fail("refineCell", "a power of two in 1..64");
    if (s.shadowCluster < 1 || s.shadowCluster > int(kBlockVals) || (s.shadowCluster & (s.shadowCluster - 1)) != 0)
        fail("shadowCluster", "a power of two in 1..16");
    if (!(s.refineTolerance > 0.0f && std::isfinite(s.refineTolerance))) fail("refineTolerance", "a finite value > 0");
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
    DiscArrays valArrays;               ///< the shadow discs (merged VALs) in spatial (Morton) order
    std::vector<std::uint64_t> valKeys; ///< sort scratch: Morton code << 32 | input index
    std::vector<ValBall> valBlocks, valGroups;
    cpu::ValArrays valSimd, emitterSimd;  ///< the SIMD gather's VALs (sorted) and emitter discs
    cpu::ReceiverArrays gatherReceivers;  ///< receivers in the region (then emitters) for the SIMD gather
    cpu::ReceiverArrays emitterReceivers; ///< the emitters as receivers of the VALs
    cpu::ReceiverArrays noReceivers;      ///< prepareGather's block boxes of the emitter discs alone
    std::vector<float> valSums, emitterSums, emitterValSums; ///< kGatherSums x padded receivers each
    std::vector<std::uint32_t> gatherList; ///< grid indices of the receivers a gather pass computes, grid order
    std::vector<DifferentialReceiver> receivers;
    /// What a pixel reads of a receiver: BGR dE and E_without, and its depth (0: not in the region).
    struct PixelNode {
        cv::Vec3f delta{0.0f, 0.0f, 0.0f}, without{0.0f, 0.0f, 0.0f};
        float depth = 0.0f;
        bool negligible = false; ///< changes its pixels by under half an 8-bit step (negligibleAt())
    };
    /// Whether receiver g cannot visibly change a pixel it is read by: its VALs' and emitters' part of
    /// dE / E_without under 1/510 (the composite scales the pixel by 1 + dE / E_without, which moves its sRGB
    /// code by at most 255 p encode'(p) / 510 <= 0.22 of a step at any brightness) and no light's segment
    /// from it within a receiver diagonal of an object's sphere (so no pixel between it and its neighbours
    /// on its surface is in an object's shadow).
    bool negligibleAt(std::size_t g) const;
    std::vector<PixelNode> pixelNodes;
    /// Per receiver in the region: the scene lights' part of dE (exact at every receiver: the edges of the
    /// objects' shadows and of the cones are sharp) and the rest, the VALs' and emitters' part.
    std::vector<glm::dvec3> lightDelta, indirectDelta;
    /// Per receiver and light (receiver-major): the light's irradiance where the real room lets it reach the
    /// receiver, else 0; gathered receivers compute it, the others interpolate it. Pixels read it for their
    /// own shadow test.
    std::vector<glm::dvec3> lightReach;
    std::vector<cv::Vec3f> pixelReach; ///< lightReach in float BGR, what interpolate() reads
    /// This frame's inputs, for the passes of compute().
    struct Frame {
        const cv::Mat* depth = nullptr;
        const CameraIntrinsics* intrinsics = nullptr;
        Pose world_T_camera, camera_T_world;
        std::span<const DifferentialLightSource> lights;
    } frame;
    /// The lights' positions and the objects' bounding spheres (centre, radius^2) in camera space, float: the
    /// pixels' first test of whether an object can shadow them.
    std::vector<glm::vec3> lightsInCamera;
    std::vector<glm::vec4> spheresInCamera;
    std::span<glm::dvec3> reachOf(std::size_t receiver) {
        return {lightReach.data() + receiver * frame.lights.size(), frame.lights.size()};
    }
    std::vector<AdaptiveCell> cells, nextCells;  ///< the adaptive cells of one level (scratch)
    std::vector<std::uint8_t> cellInterpolable;  ///< per cell of `cells`: its inside comes from its corners
    std::vector<AdaptiveCell> interpolatedCells; ///< coarse to fine: a finer cell's values win on a shared edge
    std::vector<std::uint8_t> queued;            ///< per receiver: in gatherList already
    std::vector<std::uint8_t> hidden;            ///< per receiver: a virtual object hides it from the camera
    int gridWidth = 0, gridHeight = 0;
    int receiverStride = 1; ///< this frame's, pixels

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
    /// Receiver (i, j): position, normal, validity and whether it is in the region (no gathering);
    /// `hiddenHere`: whether a virtual object hides it from the camera (a ray, where the sight line passes an object's
    /// sphere).
    void placeReceiver(const cv::Mat& depth, const CameraIntrinsics& k, const Pose& world_T_camera, int i, int j,
                       std::span<const DifferentialLightSource> lights, DifferentialReceiver& r,
                       std::uint8_t& hiddenHere, std::int64_t& rays) const;
    /// Receivers hidden by the objects whose neighbours are all hidden leave the region: no pixel the camera
    /// shows of the real surface reads them.
    void dropHiddenReceivers();
    /// The scene lights at receiver r (in the region): their part of dE and, if `without`, of E_without and
    /// each light's reach (else the real-geometry test runs only where it changes dE).
    void lightReceiver(const DifferentialReceiver& r, glm::dvec3& delta, glm::dvec3* without,
                       std::span<glm::dvec3> reach, std::int64_t& rays) const;
    /// Gathers the receivers of gatherList (all in the region): the SIMD sums, each one's indirect shadow
    /// and its lights.
    void gatherListed(std::int64_t& rays);
    /// Whether an adaptive cell may be interpolated from its gathered corners.
    bool interpolable(const AdaptiveCell& cell, const CameraIntrinsics& k) const;
    CellCorners cornersOf(const AdaptiveCell& cell) const;
    /// Whether some receiver of the cell (inside the grid) is in the region.
    bool anyInRegion(const AdaptiveCell& cell) const {
        for (int j = cell.j; j <= std::min(cell.j + cell.size, gridHeight - 1); ++j)
            for (int i = cell.i; i <= std::min(cell.i + cell.size, gridWidth - 1); ++i)
                if (receivers[std::size_t(j) * std::size_t(gridWidth) + std::size_t(i)].inRegion) return true;
        return false;
    }
    /// Adds receiver (i, j) to gatherList if it is in the grid and the region, not gathered and not listed.
    void queue(int i, int j);
    /// The quadtree of cells: gathers the top cells' corners, then level by level the cells that cannot be
    /// interpolated split in four (their new corners gathered) down to single receivers.
    void gatherAdaptively(const CameraIntrinsics& k, DifferentialImages& out);
    /// dE and E_without of the interpolated cells' receivers, bilinear from the cells' corners.
    void fillCells();
    /// The VALs' and emitters' part of dE and E_without at a receiver in the region (written to r); vals: the
    /// SIMD sums of the VALs (E_j summed), bounce: of the emitters.
    void gatherReceiver(const glm::dvec3& valsIrradiance, const glm::dvec3& bounce, DifferentialReceiver& r,
                        std::int64_t& rays) const;
    /// Writes every pixel of `out`: dE and E_without bilinear over the surrounding receivers on its surface,
    /// the lights' part of dE from the pixel's own shadow tests.
    void interpolate(const cv::Mat& depth, DifferentialImages& out);
    /// The lights' part of dE at a pixel (its point in camera space) that reads `nodes` with (normalised)
    /// `weights`.
    cv::Vec3f lightsAtPixel(const glm::vec3& pixel, const std::array<std::ptrdiff_t, 4>& nodes,
                            const std::array<float, 4>& weights, std::int64_t& rays) const;
    /// Per pixel column and row: (u - cx) / fx and (v - cy) / fy, the camera ray at depth 1.
    std::vector<float> pixelRayX, pixelRayY;
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
    const std::size_t padded = (n + cpu::kSumBlock - 1) / cpu::kSumBlock * cpu::kSumBlock;
    if (valSimd.px.size() < padded) valSimd.reserve(padded); // grows only past the largest frame
    for (std::size_t s = 0; s < n; ++s)
        cpu::setVal(valSimd, std::uint32_t(s), vals[std::uint32_t(valKeys[s] & 0xFFFFFFFFu)]);
    padSimdDiscs(valSimd, std::uint32_t(n));

    // The shadow discs: shadowCluster consecutive sorted VALs merged into one disc of their summed area and
    // flux at their area-weighted centre, with their area-weighted mean normal (1: the VALs themselves).
    const std::size_t cluster = std::size_t(settings.shadowCluster);
    const std::size_t m = (n + cluster - 1) / cluster;
    for (auto* v : {&valArrays.px, &valArrays.py, &valArrays.pz, &valArrays.nx, &valArrays.ny, &valArrays.nz,
                    &valArrays.r2, &valArrays.fr, &valArrays.fg, &valArrays.fb})
        v->assign((m + kBlockVals - 1) / kBlockVals * kBlockVals, 0.0f); // zero discs pad the last block
    for (std::size_t d = 0; d < m; ++d) {
        double area = 0.0;
        glm::dvec3 centre(0.0), normal(0.0), flux(0.0);
        for (std::size_t s = d * cluster; s < std::min(n, d * cluster + cluster); ++s) {
            const VirtualAreaLight& l = vals[std::uint32_t(valKeys[s] & 0xFFFFFFFFu)];
            area += double(l.area);
            centre += double(l.area) * glm::dvec3(l.position);
            normal += double(l.area) * glm::dvec3(l.normal);
            flux += glm::dvec3(l.flux);
        }
        const VirtualAreaLight& first = vals[std::uint32_t(valKeys[d * cluster] & 0xFFFFFFFFu)];
        centre /= area;
        normal = glm::length(normal) > 0.0 ? glm::normalize(normal) : glm::dvec3(first.normal);
        valArrays.px[d] = float(centre.x);
        valArrays.py[d] = float(centre.y);
        valArrays.pz[d] = float(centre.z);
        valArrays.nx[d] = float(normal.x);
        valArrays.ny[d] = float(normal.y);
        valArrays.nz[d] = float(normal.z);
        valArrays.r2[d] = float(area / std::numbers::pi);
        valArrays.fr[d] = float(flux.x);
        valArrays.fg[d] = float(flux.y);
        valArrays.fb[d] = float(flux.z);
    }

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
    for (std::size_t first = 0; first < m; first += kBlockVals) {
        const std::size_t last = std::min(first + kBlockVals, m);
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
                                                 DifferentialReceiver& r, std::uint8_t& hiddenHere,
                                                 std::int64_t& rays) const {
    r = DifferentialReceiver{};
    hiddenHere = 0;
    const int s = receiverStride, R = settings.normalWindowRadius;
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
    if (r.inRegion) hiddenHere = blocked(r.position, world_T_camera.translation(), rays) ? 1 : 0;
}

void DifferentialIrradiance::Impl::dropHiddenReceivers() {
    const auto covered = [this](int i, int j) {
        if (i < 0 || j < 0 || i >= gridWidth || j >= gridHeight) return true;
        const std::size_t g = std::size_t(j) * std::size_t(gridWidth) + std::size_t(i);
        return hidden[g] != 0;
    };
    for (int j = 0; j < gridHeight; ++j)
        for (int i = 0; i < gridWidth; ++i) {
            DifferentialReceiver& r = receivers[std::size_t(j) * std::size_t(gridWidth) + std::size_t(i)];
            if (!r.inRegion || !covered(i, j)) continue;
            bool inside = true;
            for (int dj = -1; dj <= 1 && inside; ++dj)
                for (int di = -1; di <= 1 && inside; ++di) inside = covered(i + di, j + dj);
            if (inside) r.inRegion = false;
        }
}

void DifferentialIrradiance::Impl::lightReceiver(const DifferentialReceiver& r, glm::dvec3& delta, glm::dvec3* without,
                                                 std::span<glm::dvec3> reach, std::int64_t& rays) const {
    delta = glm::dvec3(0.0);
    if (without != nullptr) *without = glm::dvec3(0.0);
    std::fill(reach.begin(), reach.end(), glm::dvec3(0.0));
    for (std::size_t l = 0; l < frame.lights.size(); ++l) {
        const DifferentialLightSource& source = frame.lights[l];
        const glm::dvec3 e = lightIrradiance(r.position, r.normal, source.light);
        if (e == glm::dvec3(0.0)) continue;
        const glm::dvec3 light = toDouble(source.light.position);
        const bool shadowed = blocked(r.position, light, rays);
        // A light that real geometry hides is in neither image; an in-room light's only change is its shadow.
        const bool changes = source.inRoom ? shadowed : !shadowed;
        if (!changes && without == nullptr) continue;
        if (reallyOccluded(*frame.depth, *frame.intrinsics, frame.camera_T_world, r.position, light)) continue;
        if (without != nullptr) {
            reach[l] = e;
            if (source.inRoom) *without += e;
        }
        if (changes) delta += source.inRoom ? -e : e;
    }
}

void DifferentialIrradiance::Impl::gatherReceiver(const glm::dvec3& valsIrradiance, const glm::dvec3& bounce,
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
    // Summed in the shadow discs' spatial order (the per-pair loop used the input order: rounding only).
    for (const auto& [v, w] : candidates) {
        ++rays;
        if (occluded(x, glm::dvec3(valArrays.px[v], valArrays.py[v], valArrays.pz[v]))) // the indirect shadow
            delta -= glm::dvec3(valArrays.fr[v], valArrays.fg[v], valArrays.fb[v]) * double(w);
    }
    delta += bounce; // the light the objects reflect
    r.irradianceWithout = finite(without) ? without : glm::dvec3(0.0);
    r.deltaIrradiance = finite(delta) ? delta : glm::dvec3(0.0);
}

void DifferentialIrradiance::Impl::interpolate(const cv::Mat& depth, DifferentialImages& out) {
    // The receivers the pixels read, compact and in float BGR (depth 0: not in the region).
    const std::size_t lightCount = frame.lights.size();
    pixelNodes.resize(receivers.size());
    pixelReach.resize(lightReach.size());
    const auto bgr = [](const glm::dvec3& rgb) { return cv::Vec3f(float(rgb.z), float(rgb.y), float(rgb.x)); };
    for (std::size_t g = 0; g < receivers.size(); ++g) {
        const DifferentialReceiver& r = receivers[g];
        pixelNodes[g] = r.inRegion
                            ? PixelNode{bgr(indirectDelta[g]), bgr(r.irradianceWithout), r.depth, negligibleAt(g)}
                            : PixelNode{};
        for (std::size_t l = 0; l < lightCount; ++l)
            pixelReach[g * lightCount + l] = r.inRegion ? bgr(lightReach[g * lightCount + l]) : cv::Vec3f();
    }
    const CameraIntrinsics& k = *frame.intrinsics;
    pixelRayX.resize(std::size_t(depth.cols));
    pixelRayY.resize(std::size_t(depth.rows));
    for (int u = 0; u < depth.cols; ++u) pixelRayX[std::size_t(u)] = float((double(u) - k.cx) / k.fx);
    for (int v = 0; v < depth.rows; ++v) pixelRayY[std::size_t(v)] = float((double(v) - k.cy) / k.fy);
    const int s = receiverStride;
    const float relative = settings.maxDepthChange;
    std::atomic<std::int64_t> rays{0};
    cv::parallel_for_(cv::Range(0, depth.rows), [&](const cv::Range& range) {
        std::int64_t localRays = 0;
        for (int v = range.start; v < range.end; ++v) {
            auto* delta = out.deltaIrradiance.ptr<cv::Vec3f>(v);
            auto* without = out.irradianceWithout.ptr<cv::Vec3f>(v);
            auto* affected = out.affected.ptr<std::uint8_t>(v);
            const float* zRow = depth.ptr<float>(v);
            // Grid node j sits at pixel row j s + s/2; the pixels between nodes i0 and i0 + 1 of rows j0 and
            // j0 + 1 read the same four (a node off the grid or the region is absent).
            const float gy = float(v - s / 2) / float(s);
            const int j0 = int(std::floor(gy));
            const float fy = gy - float(j0);
            const auto node = [&](int i, int j) -> std::ptrdiff_t {
                if (i < 0 || j < 0 || i >= gridWidth || j >= gridHeight) return -1;
                const std::size_t g = std::size_t(j) * std::size_t(gridWidth) + std::size_t(i);
                return pixelNodes[g].depth != 0.0f ? std::ptrdiff_t(g) : -1;
            };
            for (int i0 = -1; i0 < gridWidth; ++i0) {
                const int uBegin = std::max(0, i0 * s + s / 2), uEnd = std::min(depth.cols, (i0 + 1) * s + s / 2);
                const std::array<std::ptrdiff_t, 4> nodes{node(i0, j0), node(i0 + 1, j0), node(i0, j0 + 1),
                                                          node(i0 + 1, j0 + 1)};
                std::fill(delta + uBegin, delta + uEnd, cv::Vec3f());
                std::fill(without + uBegin, without + uEnd, cv::Vec3f());
                std::fill(affected + uBegin, affected + uEnd, std::uint8_t(0));
                const auto skip = [this](std::ptrdiff_t g) { return g < 0 || pixelNodes[std::size_t(g)].negligible; };
                if (skip(nodes[0]) && skip(nodes[1]) && skip(nodes[2]) && skip(nodes[3])) continue;
                for (int u = uBegin; u < uEnd; ++u) {
                    const float zp = zRow[u];
                    if (!(zp > settings.minDepth && zp <= settings.maxDepth)) continue;
                    const float fx = float(u - s / 2) / float(s) - float(i0);
                    std::array<float, 4> weights{};
                    float weightSum = 0.0f;
                    for (std::size_t n = 0; n < 4; ++n) {
                        if (nodes[n] < 0) continue;
                        const PixelNode& r = pixelNodes[std::size_t(nodes[n])];
                        const int di = int(n & 1), dj = int(n >> 1);
                        const int distance =
                            std::max(std::abs(u - ((i0 + di) * s + s / 2)), std::abs(v - ((j0 + dj) * s + s / 2)));
                        if (std::abs(r.depth - zp) > relative * zp * float(std::max(1, distance)))
                            continue; // another surface
                        weights[n] = (di == 0 ? 1.0f - fx : fx) * (dj == 0 ? 1.0f - fy : fy);
                        weightSum += weights[n];
                    }
                    if (!(weightSum > 0.0f)) continue;
                    cv::Vec3f d(0.0f, 0.0f, 0.0f), w(0.0f, 0.0f, 0.0f);
                    for (float& weight : weights) weight /= weightSum;
                    for (std::size_t n = 0; n < 4; ++n) {
                        if (weights[n] == 0.0f) continue;
                        const PixelNode& r = pixelNodes[std::size_t(nodes[n])];
                        d += weights[n] * r.delta;
                        w += weights[n] * r.without;
                    }
                    if (!frame.lights.empty())
                        d +=
                            lightsAtPixel(glm::vec3(pixelRayX[std::size_t(u)] * zp, pixelRayY[std::size_t(v)] * zp, zp),
                                          nodes, weights, localRays);
                    delta[u] = d;
                    without[u] = w;
                    affected[u] = 255;
                }
            }
        }
        rays += localRays;
    });
    out.shadowRays += rays.load();
}

bool DifferentialIrradiance::Impl::negligibleAt(std::size_t g) const {
    const DifferentialReceiver& r = receivers[g];
    constexpr double kHalfStep = 1.0 / 510.0;
    for (int c = 0; c < 3; ++c)
        if (!(std::abs(indirectDelta[g][c]) <= kHalfStep * r.irradianceWithout[c])) return false;
    const double diagonal = std::sqrt(2.0) * double(receiverStride) * double(r.depth) / frame.intrinsics->fx;
    for (const DifferentialLightSource& source : frame.lights)
        for (const BoundingSphere& sphere : spheres) {
            const double reach = sphere.radius + diagonal;
            if (segmentDistance2(r.position, toDouble(source.light.position), sphere.centre) <= reach * reach)
                return false;
        }
    return true;
}

cv::Vec3f DifferentialIrradiance::Impl::lightsAtPixel(const glm::vec3& pixel,
                                                      const std::array<std::ptrdiff_t, 4>& nodes,
                                                      const std::array<float, 4>& weights, std::int64_t& rays) const {
    // The lights' part of dE at the pixel's own point: each light's reach interpolated like dE (smooth but
    // for real shadows), its shadow by the objects tested here, so that shadow edges are as sharp as pixels.
    const std::size_t lightCount = frame.lights.size();
    cv::Vec3f d(0.0f, 0.0f, 0.0f);
    for (std::size_t l = 0; l < lightCount; ++l) {
        cv::Vec3f reach(0.0f, 0.0f, 0.0f);
        for (std::size_t n = 0; n < 4; ++n)
            if (weights[n] != 0.0f) reach += weights[n] * pixelReach[std::size_t(nodes[n]) * lightCount + l];
        if (reach == cv::Vec3f(0.0f, 0.0f, 0.0f)) continue;
        // The segment to the light passes no (widened) sphere: no object shadows the pixel, no ray needed.
        const glm::vec3 toLight = lightsInCamera[l] - pixel;
        const float length2 = std::max(glm::dot(toLight, toLight), 1.0e-30f);
        bool near = false;
        for (const glm::vec4& sphere : spheresInCamera) {
            const glm::vec3 toCentre = glm::vec3(sphere) - pixel;
            const float t = std::clamp(glm::dot(toCentre, toLight) / length2, 0.0f, 1.0f);
            const glm::vec3 offset = t * toLight - toCentre;
            near = near || glm::dot(offset, offset) <= sphere.w;
        }
        const DifferentialLightSource& source = frame.lights[l];
        bool shadowed = false;
        if (near) {
            const glm::dvec3 point = frame.world_T_camera.transformPoint(glm::dvec3(pixel));
            shadowed = blocked(point, toDouble(source.light.position), rays);
        }
        if (source.inRoom ? shadowed : !shadowed) d += source.inRoom ? -reach : reach;
    }
    return d;
}

void DifferentialIrradiance::Impl::gatherListed(std::int64_t& rays) {
    // The SIMD sums of eq. 3/4 (CpuLightSkin's kernel, float sums of 16 discs): the VALs (E_without's
    // part) and the emitter discs (the bounce); then per receiver the indirect shadow (Embree).
    const std::size_t count = gatherList.size();
    gatherReceivers.resize((count + cpu::kReceiverPadding - 1) / cpu::kReceiverPadding * cpu::kReceiverPadding);
    for (std::size_t n = 0; n < count; ++n) {
        const DifferentialReceiver& r = receivers[gatherList[n]];
        setSimdReceiver(gatherReceivers, n, r.position, r.normal);
    }
    cpu::prepareGather(valSimd, gatherReceivers, count); // coherent receiver groups, VAL block boxes
    gatherSimd(valSimd, gatherReceivers, valSums);
    gatherSimd(emitterSimd, gatherReceivers, emitterSums);
    const std::size_t stride = gatherReceivers.padded;
    const auto sum = [stride](const std::vector<float>& sums, std::size_t n) {
        return glm::dvec3(sums[0 * stride + n], sums[1 * stride + n], sums[2 * stride + n]);
    };
    std::atomic<std::int64_t> rayCount{0};
    cv::parallel_for_(cv::Range(0, int(count)), [&](const cv::Range& range) {
        std::int64_t localRays = 0;
        for (int n = range.start; n < range.end; ++n) {
            const std::size_t at = std::size_t(n);
            DifferentialReceiver& r = receivers[gatherList[at]];
            gatherReceiver(sum(valSums, at), sum(emitterSums, at), r, localRays);
            glm::dvec3 lightsWithout;
            lightReceiver(r, lightDelta[gatherList[at]], &lightsWithout, reachOf(gatherList[at]), localRays);
            r.irradianceWithout += lightsWithout;
            r.gathered = true;
        }
        rayCount += localRays;
    });
    rays += rayCount.load();
}

namespace {

/// The corners of an adaptive cell that a receiver inside may read: the gathered ones, three or four (a
/// corner off the region is a hole or an edge of the depth). A receiver at (fx, fy) in [0, 1]^2 reads them
/// with the bilinear weights renormalised over those corners, and lies on their surface if its inverse
/// depth is that of their plane: on a plane 1/z is affine in the pixel, so bilinear through four corners
/// and the plane through three.
class CellCorners {
public:
    explicit CellCorners(std::array<const DifferentialReceiver*, 4> corners)
        : corners_(corners) {
        for (std::size_t k = 0; k < 4; ++k) {
            usable_[k] = corners_[k]->gathered;
            count_ += usable_[k] ? 1 : 0;
            inverseDepth_[k] = usable_[k] ? 1.0 / double(corners_[k]->depth) : 0.0;
        }
    }
    int usable() const noexcept { return count_; }
    const DifferentialReceiver& corner(std::size_t k) const noexcept { return *corners_[k]; }
    bool isUsable(std::size_t k) const noexcept { return usable_[k]; }
    /// The renormalised weights; all 0 where no usable corner has weight (the missing corner itself).
    std::array<double, 4> weights(double fx, double fy) const noexcept {
        std::array<double, 4> a{(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy};
        double sum = 0.0;
        for (std::size_t k = 0; k < 4; ++k) sum += usable_[k] ? a[k] : (a[k] = 0.0);
        for (double& weight : a) weight = sum > 0.0 ? weight / sum : 0.0;
        return a;
    }
    double inverseDepth(double fx, double fy) const noexcept {
        const auto& w = inverseDepth_; // corners (0,0), (1,0), (0,1), (1,1)
        if (count_ == 4) return (1.0 - fy) * ((1.0 - fx) * w[0] + fx * w[1]) + fy * ((1.0 - fx) * w[2] + fx * w[3]);
        if (!usable_[3]) return w[0] + fx * (w[1] - w[0]) + fy * (w[2] - w[0]);
        if (!usable_[2]) return w[0] + fx * (w[1] - w[0]) + fy * (w[3] - w[1]);
        if (!usable_[1]) return w[0] + fx * (w[3] - w[2]) + fy * (w[2] - w[0]);
        return w[1] + w[2] - w[3] + fx * (w[3] - w[2]) + fy * (w[3] - w[1]);
    }

private:
    std::array<const DifferentialReceiver*, 4> corners_;
    std::array<bool, 4> usable_{};
    std::array<double, 4> inverseDepth_{};
    int count_ = 0;
};

} // namespace

CellCorners DifferentialIrradiance::Impl::cornersOf(const AdaptiveCell& cell) const {
    const auto at = [this](int i, int j) {
        return &receivers[std::size_t(j) * std::size_t(gridWidth) + std::size_t(i)];
    };
    const int c = cell.size;
    return CellCorners(
        {at(cell.i, cell.j), at(cell.i + c, cell.j), at(cell.i, cell.j + c), at(cell.i + c, cell.j + c)});
}

bool DifferentialIrradiance::Impl::interpolable(const AdaptiveCell& cell, const CameraIntrinsics& k) const {
    const int c = cell.size, i0 = cell.i, j0 = cell.j;
    if (i0 + c >= gridWidth || j0 + c >= gridHeight) return false;
    const CellCorners corners = cornersOf(cell);
    if (corners.usable() < 3) return false;
    // The composite scales a pixel by 1 + dE / E_without: over the corners, the VALs' and emitters' part of it
    // (the lights' part of dE is exact at every receiver) may spread by the tolerance.
    for (int channel = 0; channel < 3; ++channel) {
        double lo = std::numeric_limits<double>::infinity(), hi = -lo;
        for (std::size_t n = 0; n < 4; ++n) {
            if (!corners.isUsable(n)) continue;
            const DifferentialReceiver& r = corners.corner(n);
            if (!(r.irradianceWithout[channel] > 0.0)) return false;
            const double q = r.deltaIrradiance[channel] / r.irradianceWithout[channel];
            lo = std::min(lo, q);
            hi = std::max(hi, q);
        }
        if (hi - lo > double(settings.refineTolerance)) return false;
    }
    // Every receiver of the cell in the region: on the corners' surface (CellCorners; the interpolation's
    // relative tolerance), and at least two cell diagonals h outside every object's bounding sphere. There the
    // object's share of the hemisphere, ~ r^2 / d^2 at a distance d from its centre, has no peak (the contact
    // shadow's lies nearer) and bilinear interpolation misses at most h^2 / 8 of its second derivative
    // 6 r^2 / d^4: with d - r >= 2 h, under 5 % of its value.
    const double cellDiagonalPerMetre = std::sqrt(2.0) * double(c * receiverStride) / k.fx;
    constexpr double kClearanceDiagonals = 2.0;
    for (int j = j0; j <= j0 + c; ++j)
        for (int i = i0; i <= i0 + c; ++i) {
            const DifferentialReceiver& r = receivers[std::size_t(j) * std::size_t(gridWidth) + std::size_t(i)];
            if (!r.inRegion || r.gathered) continue;
            const double fx = double(i - i0) / double(c), fy = double(j - j0) / double(c);
            const std::array<double, 4> weights = corners.weights(fx, fy);
            if (weights[0] + weights[1] + weights[2] + weights[3] == 0.0) return false;
            const double inverseDepth = 1.0 / double(r.depth);
            if (std::abs(inverseDepth - corners.inverseDepth(fx, fy)) > double(settings.maxDepthChange) * inverseDepth)
                return false;
            for (const BoundingSphere& sphere : spheres) {
                const double reach = sphere.radius + kClearanceDiagonals * cellDiagonalPerMetre * double(r.depth);
                const glm::dvec3 offset = r.position - sphere.centre;
                if (glm::dot(offset, offset) < reach * reach) return false;
            }
        }
    return true;
}

void DifferentialIrradiance::Impl::queue(int i, int j) {
    if (i >= gridWidth || j >= gridHeight) return;
    const std::size_t g = std::size_t(j) * std::size_t(gridWidth) + std::size_t(i);
    if (!receivers[g].inRegion || receivers[g].gathered || queued[g] != 0) return;
    queued[g] = 1;
    gatherList.push_back(std::uint32_t(g));
}

void DifferentialIrradiance::Impl::gatherAdaptively(const CameraIntrinsics& k, DifferentialImages& out) {
    const int top = settings.refineCell;
    queued.assign(receivers.size(), 0);
    cells.clear();
    interpolatedCells.clear();
    gatherList.clear();
    for (int j = 0; j < gridHeight; j += top)
        for (int i = 0; i < gridWidth; i += top) {
            queue(i, j);
            if (top > 1 && i + 1 < gridWidth && j + 1 < gridHeight && anyInRegion({i, j, top}))
                cells.push_back({i, j, top});
        }
    out.receiversGathered = 0;
    for (;;) {
        std::sort(gatherList.begin(), gatherList.end()); // grid order: coherent SIMD groups
        gatherListed(out.shadowRays);
        out.receiversGathered += std::int64_t(gatherList.size());
        gatherList.clear();
        if (cells.empty()) break;
        cellInterpolable.assign(cells.size(), 0);
        cv::parallel_for_(cv::Range(0, int(cells.size())), [&](const cv::Range& range) {
            for (int n = range.start; n < range.end; ++n)
                cellInterpolable[std::size_t(n)] = interpolable(cells[std::size_t(n)], k) ? 1 : 0;
        });
        // A cell that cannot be interpolated splits in four; their corners are gathered next (a cell of one
        // receiver has only corners: they are gathered already).
        nextCells.clear();
        for (std::size_t n = 0; n < cells.size(); ++n) {
            const AdaptiveCell& cell = cells[n];
            if (cellInterpolable[n] != 0) {
                interpolatedCells.push_back(cell);
                continue;
            }
            const int half = cell.size / 2;
            for (int dj = 0; dj <= 2; ++dj)
                for (int di = 0; di <= 2; ++di) queue(cell.i + di * half, cell.j + dj * half);
            if (half < 2) continue; // the next level's cells are single receivers: all corners
            for (int dj = 0; dj < 2; ++dj)
                for (int di = 0; di < 2; ++di) {
                    const AdaptiveCell sub{cell.i + di * half, cell.j + dj * half, half};
                    if (sub.i + 1 < gridWidth && sub.j + 1 < gridHeight && anyInRegion(sub)) nextCells.push_back(sub);
                }
        }
        std::swap(cells, nextCells);
        if (gatherList.empty() && cells.empty()) break;
    }
}

void DifferentialIrradiance::Impl::fillCells() {
    // In the order the cells were found (coarse to fine): on an edge shared with a finer cell, the finer
    // cell's corners are nearer, so its values are written last.
    for (const AdaptiveCell& cell : interpolatedCells) {
        const CellCorners corners = cornersOf(cell);
        for (int j = cell.j; j <= cell.j + cell.size; ++j)
            for (int i = cell.i; i <= cell.i + cell.size; ++i) {
                DifferentialReceiver& r = receivers[std::size_t(j) * std::size_t(gridWidth) + std::size_t(i)];
                if (!r.inRegion || r.gathered) continue;
                const std::array<double, 4> weights =
                    corners.weights(double(i - cell.i) / double(cell.size), double(j - cell.j) / double(cell.size));
                r.deltaIrradiance = r.irradianceWithout = glm::dvec3(0.0);
                const std::span<glm::dvec3> reach = reachOf(std::size_t(&r - receivers.data()));
                std::fill(reach.begin(), reach.end(), glm::dvec3(0.0));
                for (std::size_t n = 0; n < 4; ++n) {
                    if (weights[n] == 0.0) continue;
                    const DifferentialReceiver& corner = corners.corner(n);
                    r.deltaIrradiance += weights[n] * corner.deltaIrradiance;
                    r.irradianceWithout += weights[n] * corner.irradianceWithout;
                    const std::span<glm::dvec3> cornerReach = reachOf(std::size_t(&corner - receivers.data()));
                    for (std::size_t l = 0; l < reach.size(); ++l) reach[l] += weights[n] * cornerReach[l];
                }
            }
    }
}

void DifferentialIrradiance::compute(const cv::Mat& depthMetres, const CameraIntrinsics& intrinsics,
                                     const Pose& world_T_camera, std::span<const VirtualAreaLight> vals,
                                     std::span<const DifferentialLightSource> lights, DifferentialImages& out) {
    LIGHTSKIN_ASSERT(impl_, "lightskin::gi::DifferentialIrradiance::compute(): used before create()");
    LIGHTSKIN_ASSERT(depthMetres.type() == CV_32FC1,
                     "lightskin::gi::DifferentialIrradiance::compute(): depth must be CV_32FC1 metres");
    Impl& impl = *impl_;
    // Automatic: 80 receivers across the image. The soft terms vary on the scale of the objects and the room, the
    // sharp ones (the lights' shadows) are tested per pixel: the truth error on synth-orbit does not change
    // from 4 to 8 pixels at 320 x 240 nor at 640 x 480 (docs/BENCHMARKS.md).
    const int s = impl.settings.receiverStride > 0 ? impl.settings.receiverStride : std::max(2, depthMetres.cols / 80);
    impl.receiverStride = s;
    impl.gridWidth = depthMetres.cols / s;
    impl.gridHeight = depthMetres.rows / s;
    const std::size_t gridSize = std::size_t(impl.gridWidth) * std::size_t(impl.gridHeight);
    impl.receivers.resize(gridSize);
    impl.lightDelta.resize(gridSize);
    impl.indirectDelta.resize(gridSize);
    impl.lightReach.resize(gridSize * lights.size());
    out.deltaIrradiance.create(depthMetres.size(), CV_32FC3);
    out.irradianceWithout.create(depthMetres.size(), CV_32FC3);
    out.affected.create(depthMetres.size(), CV_8UC1);
    out.shadowRays = 0;

    impl.sortVals(vals);
    impl.updateEmitters(lights, out.shadowRays);
    impl.frame = {&depthMetres, &intrinsics, world_T_camera, world_T_camera.inverse(), lights};
    impl.lightsInCamera.clear();
    for (const DifferentialLightSource& source : lights)
        impl.lightsInCamera.push_back(
            glm::vec3(impl.frame.camera_T_world.transformPoint(toDouble(source.light.position))));
    impl.spheresInCamera.clear();
    for (const BoundingSphere& sphere : impl.spheres) // the radius widened by 1 mm for the float test's rounding
        impl.spheresInCamera.push_back(glm::vec4(glm::vec3(impl.frame.camera_T_world.transformPoint(sphere.centre)),
                                                 float((sphere.radius + 1e-3) * (sphere.radius + 1e-3))));

    // 1. Every receiver's geometry and whether it is in the region (rows in parallel).
    impl.hidden.resize(gridSize);
    std::atomic<std::int64_t> sightRays{0};
    cv::parallel_for_(cv::Range(0, impl.gridHeight), [&](const cv::Range& range) {
        std::int64_t localRays = 0;
        for (int j = range.start; j < range.end; ++j)
            for (int i = 0; i < impl.gridWidth; ++i) {
                const std::size_t g = std::size_t(j) * std::size_t(impl.gridWidth) + std::size_t(i);
                impl.placeReceiver(depthMetres, intrinsics, world_T_camera, i, j, lights, impl.receivers[g],
                                   impl.hidden[g], localRays);
            }
        sightRays += localRays;
    });
    out.shadowRays += sightRays.load();
    impl.dropHiddenReceivers();
    // 2. E_without and dE but for the lights' part of dE: the adaptive cells' corners, then the cells that
    // vary or need detail split level by level (every receiver when refineCell is 1); the interpolated cells
    // from their corners.
    impl.gatherAdaptively(intrinsics, out);
    impl.fillCells();
    // 3. The lights' part of dE at the interpolated receivers, exactly; dE = both parts.
    std::atomic<std::int64_t> lightRays{0};
    cv::parallel_for_(cv::Range(0, impl.gridHeight), [&](const cv::Range& range) {
        std::int64_t localRays = 0;
        for (int j = range.start; j < range.end; ++j)
            for (int i = 0; i < impl.gridWidth; ++i) {
                const std::size_t g = std::size_t(j) * std::size_t(impl.gridWidth) + std::size_t(i);
                DifferentialReceiver& r = impl.receivers[g];
                if (!r.inRegion) continue;
                if (!r.gathered) impl.lightReceiver(r, impl.lightDelta[g], nullptr, {}, localRays);
                impl.indirectDelta[g] = r.deltaIrradiance;
                r.deltaIrradiance += impl.lightDelta[g];
                if (!finite(r.deltaIrradiance)) r.deltaIrradiance = glm::dvec3(0.0);
                if (!finite(r.irradianceWithout)) r.irradianceWithout = glm::dvec3(0.0);
            }
        lightRays += localRays;
    });
    out.shadowRays += lightRays.load();
    out.receiversInRegion = std::count_if(impl.receivers.begin(), impl.receivers.end(),
                                          [](const DifferentialReceiver& r) { return r.inRegion; });
    impl.interpolate(depthMetres, out);
}

std::span<const DifferentialReceiver> DifferentialIrradiance::receivers() const noexcept { return impl_->receivers; }
int DifferentialIrradiance::gridWidth() const noexcept { return impl_->gridWidth; }
int DifferentialIrradiance::gridHeight() const noexcept { return impl_->gridHeight; }
int DifferentialIrradiance::receiverStride() const noexcept { return impl_->receiverStride; }
std::span<const VirtualAreaLight> DifferentialIrradiance::emitters() const noexcept { return impl_->emitters; }
const DifferentialSettings& DifferentialIrradiance::settings() const noexcept { return impl_->settings; }

void downloadValsInto(const ValSetView& set, std::vector<VirtualAreaLight>& out) {
    out.resize(set.count);
    if (set.count == 0) return;
    glGetNamedBufferSubData(set.buffer, 0, GLsizeiptr(sizeof(VirtualAreaLight) * set.count), out.data());
}

} // namespace lightskin::gi
