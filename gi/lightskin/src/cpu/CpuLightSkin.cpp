// CpuLightSkin: LightSkin stages 0-4 on the CPU (see the header), stage 5 on GL. The loops and
// bookkeeping are here; the SIMD kernels in CpuGatherKernels.cpp; every per-point formula is the
// double instance of lightskin_math.glsl (reference/LightSkinMath.h).
#include "CpuGatherKernels.h"
#include "CpuNearField.h"
#include "CpuValTreeGather.h"
#include "common/src/GatherShaders.h"
#include "common/src/TsanParallelRegion.h"
#include "lightskin/src/LightSkinMath.h"

#include <lightskin/core/CpuTime.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/core/SimdTarget.h>
#include <lightskin/gi/lightskin/BuriedSparsePoints.h>
#include <lightskin/gi/lightskin/CpuLightSkin.h>
#include <lightskin/gl/ShaderLibrary.h>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <ctime>
#include <limits>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace lightskin::gi {

namespace {

namespace m = refmath;
using Clock = std::chrono::steady_clock;

double millisecondsSince(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// Per parallel region, the CPU time of each arena slot's tasks (slot = oneTBB's thread index in the
/// arena; each slot written by its own thread only), folded after the join into the frame's excess
/// of the busiest slot over the calling thread's own slot: the calling thread's CPU time plus that
/// excess over all regions is CpuLightSkinStats::criticalPathCpuMs. Only thread CPU clocks: a
/// worker's spinning between regions or another process's load do not enter it.
struct RegionClock {
    std::vector<double> slotMs; // sized once per arena (no allocation per frame)
    int callerSlot = -1;        // the calling thread's slot in this region (set inside arena.execute)
    double excessMs = 0.0;      // this frame: sum over regions of (max - caller's) slot time
    void resize(std::size_t slots) { slotMs.assign(slots, 0.0); }
    void begin() { std::fill(slotMs.begin(), slotMs.end(), 0.0); }
    void enter() { callerSlot = tbb::this_task_arena::current_thread_index(); }
    void add(double ms) {
        const int slot = tbb::this_task_arena::current_thread_index();
        if (slot >= 0 && std::size_t(slot) < slotMs.size()) slotMs[std::size_t(slot)] += ms;
    }
    void end() {
        double largest = 0.0;
        for (const double ms : slotMs) largest = std::max(largest, ms);
        const double caller =
            callerSlot >= 0 && std::size_t(callerSlot) < slotMs.size() ? slotMs[std::size_t(callerSlot)] : 0.0;
        excessMs += largest - caller;
    }
};

std::size_t padReceivers(std::size_t n) {
    return (n + cpu::kReceiverPadding - 1) / cpu::kReceiverPadding * cpu::kReceiverPadding;
}

/// Runs body(begin, end) in `arena` over [0, count) split into one contiguous,
/// kReceiverPadding-aligned range per thread of the arena. The split only decides who computes a
/// receiver, never how. oneTBB, not OpenMP: libgomp's idle workers spin between parallel regions
/// (OMP_WAIT_POLICY defaults to active) and took 30 % of the replay's CPU time from llvmpipe and the
/// tracker on 2 cores (docs/BENCHMARKS.md, "SIMD and thread libraries").
/// `splits` (optional): thread t's groups are [splits[t], splits[t + 1]), max_concurrency() + 1
/// group boundaries from 0 to count / kReceiverPadding; empty: equal numbers of groups.
template <class Body>
void parallelRanges(tbb::task_arena& arena, RegionClock& clock, std::size_t count, const Body& body,
                    std::span<const std::size_t> splits = {}) {
    struct Context {
        std::size_t groups, n;
        std::span<const std::size_t> splits;
        const Body& body;
        RegionClock& clock;
        detail::TsanParallelRegion region; // last: the fork edge follows the fields above
    };
    clock.begin(); // before the fork edge (the context's construction), read after the join (its end)
    {
        const std::size_t n = std::size_t(arena.max_concurrency());
        LIGHTSKIN_ASSERT(splits.empty() || splits.size() == n + 1, "parallelRanges(): one split per thread + 1");
        Context context{count / cpu::kReceiverPadding, n, splits, body, clock, {}};
        arena.execute([&context] {
            context.clock.enter();
            tbb::parallel_for(
                tbb::blocked_range<std::size_t>(0, context.n, 1),
                [ctx = &context](const tbb::blocked_range<std::size_t>& threads) {
                    const Context& c = *detail::TsanParallelRegion::captured(ctx);
                    c.region.taskBegin();
                    const double start = threadCpuMs();
                    for (std::size_t t = threads.begin(); t < threads.end(); ++t) {
                        const std::size_t begin =
                            (c.splits.empty() ? c.groups * t / c.n : c.splits[t]) * cpu::kReceiverPadding;
                        const std::size_t end =
                            (c.splits.empty() ? c.groups * (t + 1) / c.n : c.splits[t + 1]) * cpu::kReceiverPadding;
                        if (begin < end) c.body(begin, end);
                    }
                    c.clock.add(threadCpuMs() - start);
                    c.region.taskEnd();
                },
                tbb::static_partitioner());
        });
    }
    clock.end();
}

/// Runs body() once on each thread of `arena` (one task per thread); the bodies share out the work
/// themselves (e.g. an atomic counter over receiver groups), so a thread that starts late or loses its
/// core to another process leaves its share to the others instead of holding up the join.
template <class Body>
void parallelWorkers(tbb::task_arena& arena, RegionClock& clock, const Body& body) {
    struct Context {
        const Body& body;
        RegionClock& clock;
        detail::TsanParallelRegion region; // last: the fork edge follows the fields above
    };
    clock.begin(); // before the fork edge (the context's construction), read after the join (its end)
    {
        const std::size_t n = std::size_t(arena.max_concurrency());
        Context context{body, clock, {}};
        arena.execute([&context, n] {
            context.clock.enter();
            tbb::parallel_for(
                tbb::blocked_range<std::size_t>(0, n, 1),
                [ctx = &context](const tbb::blocked_range<std::size_t>& threads) {
                    const Context& c = *detail::TsanParallelRegion::captured(ctx);
                    c.region.taskBegin();
                    const double start = threadCpuMs();
                    for (std::size_t t = threads.begin(); t < threads.end(); ++t) c.body();
                    c.clock.add(threadCpuMs() - start);
                    c.region.taskEnd();
                },
                tbb::static_partitioner());
        });
    }
    clock.end();
}

/// body(i) for i in [begin, end) in `arena` (each i independent), the threads taking `chunk` indices at a
/// time from a shared counter: a thread that starts late (a sleeping worker's wake-up, ~20-50 us here) or
/// is preempted leaves its share to the others.
template <class Body>
void parallelFor(tbb::task_arena& arena, RegionClock& clock, std::size_t begin, std::size_t end, const Body& body,
                 std::size_t chunk = 1) {
    std::atomic<std::size_t> next{begin};
    parallelWorkers(arena, clock, [&] {
        for (std::size_t c = next.fetch_add(chunk, std::memory_order_relaxed); c < end;
             c = next.fetch_add(chunk, std::memory_order_relaxed))
            for (std::size_t i = c; i < std::min(c + chunk, end); ++i) body(i);
    });
}

/// Whether `linear` (world_T_model's 3x3 part) is a similarity: L^T L = s^2 (I + E) with every
/// |E_ij| <= kSimilarity. Then world distances are s |d| (1 + O(1.5 kSimilarity)) and the normals'
/// dot products change by O(3 kSimilarity), so the model-space weights of eq. 12 (each a product of
/// two such terms in [0, 1], normalised) differ from the world-space ones by O(10 kSimilarity) =
/// 1e-4 of the vertex's VPL at most, against gi_cpu_lightskin_gl_test's 6e-3 vertex tolerance. Why not
/// 0: world_T_model is float, a rotation rounded to float is orthogonal only to ~3 x 6e-8 per entry
/// (times the few products that built it).
bool isSimilarity(const glm::dmat3& linear) {
    constexpr double kSimilarity = 1e-5;
    const glm::dmat3 g = glm::transpose(linear) * linear;
    const double s2 = (g[0][0] + g[1][1] + g[2][2]) / 3.0;
    if (!(s2 > 0.0) || !std::isfinite(s2)) return false;
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r)
            if (!(std::abs(g[c][r] - (c == r ? s2 : 0.0)) <= kSimilarity * s2)) return false;
    return true;
}

/// Eq. 12's weights (no point buried) of vertex v of `mesh` over its neighbours in `set`, from
/// model-space positions and normals (see CpuLightSkin::Impl::modelWeights).
std::array<double, kVertexNeighbours> modelVertexWeights(const TriangleMesh& mesh, std::size_t v,
                                                         const SparsePointSet& set) {
    const glm::dvec3 p(mesh.positions[v]);
    const glm::dvec3 nv = glm::normalize(glm::dvec3(mesh.normals[v]));
    const auto& list = set.vertexNeighbours[v];
    double dist[kVertexNeighbours], cosN[kVertexNeighbours];
    bool unique[kVertexNeighbours];
    for (std::size_t j = 0; j < std::size_t(kVertexNeighbours); ++j) {
        const SparsePoint& x = set.points[list[j]];
        dist[j] = glm::length(p - glm::dvec3(x.position));
        cosN[j] = glm::dot(nv, glm::normalize(glm::dvec3(x.normal)));
        unique[j] = j == 0 || list[j] != list[j - 1];
    }
    const m::VertexWeights weights = m::ls_vertexWeights(dist, cosN, unique);
    std::array<double, kVertexNeighbours> out{};
    std::copy_n(weights.w, kVertexNeighbours, out.begin());
    return out;
}

} // namespace

struct CpuLightSkin::Impl {
    CpuLightSkinSettings settings;
    SparsePointProvider provider;
    gl::ShaderLibrary library{embeddedShaders()};
    gl::Program shade;
    gl::Framebuffer shadeFramebuffer;
    gl::GpuStageTimer timer;
    std::vector<gl::StageTime> stageTimes;
    CpuLightSkinStats stats;

    // Prepared data.
    std::vector<SparsePointSet> sparse;
    std::vector<std::uint32_t> sparseOffsets, vertexOffsets;
    std::vector<bool> convex;
    std::uint32_t pointCount = 0, vertexCount = 0;
    std::vector<glm::dvec3> modelVertexPositions, modelVertexNormals;     // per global vertex, model space
    std::vector<glm::dmat4> meshTransforms;                               // interpolate(): per instance, world_T_model
    std::vector<glm::dmat3> meshNormalMatrices;                           // and its normal matrix
    std::vector<std::array<std::uint32_t, kVertexNeighbours>> neighbours; // global sparse-point indices
    /// Eq. 12's normalised weights of each vertex's neighbours with none buried (G11), from the model-space
    /// distances and normals: a similarity transform (rotation, uniform scale, translation) keeps the
    /// ratios d_j / d_max and the normals' dot products, so these are the world-space weights of any frame
    /// whose transform is one (interpolate(): isSimilarity()); ~40 % of the interpolation's work per frame.
    std::vector<std::array<double, kVertexNeighbours>> modelWeights; // per global vertex
    std::vector<std::uint8_t> meshSimilar;                           // interpolate(): per instance, this frame
    gl::Buffer vertexVplBuffer;

    // Per-frame data, sized in prepare() (VALs: grown when a frame brings more).
    std::vector<VirtualAreaLight> staging;
    std::vector<std::uint32_t> stagingKeys; // render(): the VALs' pixel keys (quadtree), grown when needed
    cpu::ValArrays vals;
    double valSums[8] = {}; // sum l (3), sum r^2, sum l^2 per axis (3), count: eps_l terms of eq. 7
    /// buildValArrays()'s chunks of output VALs (whole blocks: each chunk's boxes are its own).
    static constexpr std::uint32_t kValChunk = 1024;
    static_assert(kValChunk % cpu::kSumBlock == 0);
    std::vector<std::uint32_t> chunkInput;              // per chunk: the input index of its first valid VAL
    std::vector<std::array<double, 8>> chunkSums;       // per chunk: its share of valSums
    std::vector<glm::dvec3> pointPosition, pointNormal; // world, per sparse point
    std::vector<double> pointExponent, pointOccluderRadius;
    cpu::ReceiverArrays receivers;
    std::vector<float> sums; // kGatherSums x padded receivers
    std::vector<m::Vpl> vplD, vplS;
    std::vector<double> gatheredPeakD;     // G10: peak RGB channel of L'_d per sparse point, W/m^2
    std::vector<std::uint8_t> pointBuried; // G11: 1 = under the real surface, per sparse point
    cpu::OcclusionReceivers occlusionReceivers;
    cpu::Occluders occluders;
    std::vector<float> occlusionD, occlusionS;         // per point
    std::vector<float> occlusionSlotD, occlusionSlotS; // per gather slot (occludeSlots())
    std::vector<glm::vec4> vertexVpls;                 // 4 vec4 per vertex, gather_vertex_vpl.glsl's layout
    /// What stage 4 takes from sparse point i, whichever vertex: its VPLs with the occlusion's
    /// keep factor (1 - o) applied, G8's distances and G10's peak. ~100 vertices read each point:
    /// made once per point (makePointTerms(): the same operations on the same values as they were
    /// per vertex, so the same bits).
    struct PointTerms {
        glm::dvec4 diffuse, diffusePosition, glossy, glossyPosition; // eq. 13's summands before w
        double minDD = 0.0, minDS = 0.0, cap = 0.0;                  // G8 (|x_vpl - x|^2 + r^2), G10
    };
    std::vector<PointTerms> pointTerms; // per sparse point
    bool pointTermsReady = false;       // this frame's pointTerms are made
    bool glossy = true, occlusion = true;
    double readbackMs = 0.0;            // render(): the VAL read-back, counted in the upload stage
    cpu::ValTreeCut treeCut;            // LightSkinSettings::valTreeThreshold > 0
    cpu::NearFieldCorrection nearField; // guard G12 (LightSkinSettings::nearFieldArea) of the flat gather

    std::unique_ptr<tbb::task_arena> arena;         // settings.threads workers (0: one per hardware thread)
    RegionClock regionClock;                        // per-thread CPU time of the parallel regions (stats)
    std::atomic<std::uint64_t> occlusionSkipped{0}; // this frame: (occluder, point) pairs skipped (stats)
    RegionClock occlusionClock;                     // per-thread time in occludeSlots() (stats; steady clock)
    // planLayout(): per group of the sorted order its time estimate (us); the groups in the order the
    // threads take them (layout, slot group -> sorted group)
    std::vector<double> groupCost;
    static constexpr std::size_t kCostFrames = 4;
    std::vector<double> recentTimes; // kCostFrames x groups: the last frames' times per sorted group (ring)
    std::size_t costFrame = 0;       // this frame's row of recentTimes
    std::vector<std::uint32_t> layout;
    int threadCount() const { return arena->max_concurrency(); }
    void createArena() {
        arena = std::make_unique<tbb::task_arena>(settings.threads > 0 ? settings.threads
                                                                       : int(tbb::task_arena::automatic));
        regionClock.resize(std::size_t(arena->max_concurrency()));
        occlusionClock.resize(std::size_t(arena->max_concurrency()));
    }

    void reserveVals(std::size_t count) {
        const std::size_t padded = (count + cpu::kSumBlock - 1) / cpu::kSumBlock * cpu::kSumBlock;
        if (vals.px.size() >= padded && staging.size() >= count) return;
        const std::size_t capacity = std::max<std::size_t>(padded, settings.lightSkin.valCapacity);
        if (!vals.px.empty()) log::info("lightskin-cpu: VAL arrays grow to " + std::to_string(capacity) + " lights");
        staging.resize(capacity);
        vals.reserve(capacity);
        chunkInput.resize(capacity / kValChunk + 1);
        chunkSums.resize(capacity / kValChunk + 1);
    }

    /// Stage 0: the valid VALs into SoA (input order kept), the eps_l sums, padding to kSumBlock and
    /// the blocks' boxes (cpu::valBlockBoxes), in the threads by chunks of kValChunk output VALs (a
    /// serial pass over the areas alone finds each chunk's first input VAL); beside them, as one more
    /// item of the same region, the sparse points in world space (placePoints) and, for the flat
    /// gather (`orderGroups`), their coherent groups in the order the gather takes them
    /// (orderReceivers): both independent of the VALs, they were serial (~0.1 ms) before the region.
    void buildValArrays(std::span<const VirtualAreaLight> lights, std::span<const MeshInstance> instances,
                        const glm::dvec3& eye, bool orderGroups) {
        reserveVals(lights.size());
        std::uint32_t n = 0;
        for (std::size_t i = 0; i < lights.size(); ++i) {
            if (!(lights[i].area > 0.0f)) continue; // invalid: adds exactly 0 (ls_gatherSample)
            if (n % kValChunk == 0) chunkInput[n / kValChunk] = std::uint32_t(i);
            ++n;
        }
        vals.count = n;
        vals.padded = (n + cpu::kSumBlock - 1) / cpu::kSumBlock * cpu::kSumBlock;
        const std::size_t chunks = (vals.padded + kValChunk - 1) / kValChunk;
        // item 0 (the longest, ~0.1 ms, so first): the points; items 1..chunks: the VAL chunks
        parallelFor(*arena, regionClock, 0, chunks + 1, [&](std::size_t item) {
            if (item > 0) {
                buildValChunk(lights, item - 1);
                return;
            }
            placePoints(instances, eye);
            if (!orderGroups) return;
            const std::size_t full = pointCount / cpu::kReceiverPadding;
            planLayout(full);
            costFrame = (costFrame + 1) % kCostFrames;
            cpu::orderReceivers(receivers, pointCount, std::span<const std::uint32_t>(layout).first(full));
        });
        // per chunk, then the chunks in order: the same bits whichever thread summed a chunk
        std::fill(std::begin(valSums), std::end(valSums), 0.0);
        for (std::size_t c = 0; c < chunks; ++c)
            for (std::size_t k = 0; k < 8; ++k) valSums[k] += chunkSums[c][k];
    }

    /// buildValArrays()'s output VALs [c kValChunk, (c + 1) kValChunk): SoA, eps_l sums, padding, boxes.
    void buildValChunk(std::span<const VirtualAreaLight> lights, std::size_t c) {
        const std::uint32_t first = std::uint32_t(c) * kValChunk;
        const std::uint32_t end = std::min(first + kValChunk, vals.count);
        const std::uint32_t paddedEnd = std::min(first + kValChunk, vals.padded);
        std::array<double, 8> s{}; // sum l (3), sum r^2, sum l^2 per axis (3), count
        std::size_t i = chunkInput[c];
        for (std::uint32_t n = first; n < end; ++i) {
            const VirtualAreaLight& l = lights[i];
            if (!(l.area > 0.0f)) continue;
            cpu::setVal(vals, n, l);
            const glm::dvec3 p(l.position);
            s[0] += p.x;
            s[1] += p.y;
            s[2] += p.z;
            s[3] += double(l.area) / m::kPi;
            s[4] += p.x * p.x;
            s[5] += p.y * p.y;
            s[6] += p.z * p.z;
            s[7] += 1.0;
            ++n;
        }
        for (std::uint32_t j = end; j < paddedEnd; ++j) { // zero-area, zero-flux VALs at the origin: add +0
            for (auto* v : {&vals.px, &vals.py, &vals.pz, &vals.negNx, &vals.negNy, &vals.r2, &vals.cr2, &vals.fr,
                            &vals.fg, &vals.fb})
                (*v)[j] = 0.0f;
            vals.negNz[j] = -1.0f;
        }
        chunkSums[c] = s;
        cpu::valBlockBoxes(vals, first / cpu::kSumBlock, paddedEnd / cpu::kSumBlock);
    }

    /// World-space sparse points (double, as reference::receiversFromSparsePoints) and the gather's SoA.
    void placePoints(std::span<const MeshInstance> instances, const glm::dvec3& eye) {
        std::size_t at = 0;
        const double c = double(settings.lightSkin.cParameter);
        for (std::size_t mesh = 0; mesh < instances.size(); ++mesh) {
            const glm::dmat4 transform(instances[mesh].world_T_model);
            const glm::dmat3 linear(transform);
            const glm::dmat3 normalMatrix = glm::transpose(glm::inverse(linear));
            const double scale = std::cbrt(std::abs(glm::determinant(linear)));
            const double k = std::max(double(instances[mesh].material.specularExponent), 1.0);
            for (const SparsePoint& p : sparse[mesh].points) {
                const glm::dvec3 x(transform * glm::dvec4(glm::dvec3(p.position), 1.0));
                const glm::dvec3 n = glm::normalize(normalMatrix * glm::dvec3(p.normal));
                const glm::dvec3 e = m::ls_toEye(x, eye);
                pointPosition[at] = x;
                pointNormal[at] = n;
                pointExponent[at] = k;
                pointOccluderRadius[at] = double(p.occluderRadius) * scale;
                receivers.px[at] = float(x.x);
                receivers.py[at] = float(x.y);
                receivers.pz[at] = float(x.z);
                receivers.nx[at] = float(n.x);
                receivers.ny[at] = float(n.y);
                receivers.nz[at] = float(n.z);
                receivers.ex[at] = float(e.x);
                receivers.ey[at] = float(e.y);
                receivers.ez[at] = float(e.z);
                const glm::dvec3 mirror = 2.0 * glm::dot(n, e) * n - e; // eq. 5: cos(gamma) = t . mirror
                receivers.rx[at] = float(mirror.x);
                receivers.ry[at] = float(mirror.y);
                receivers.rz[at] = float(mirror.z);
                receivers.k[at] = float(k);
                receivers.ck[at] = float(c * (k + 1.0));
                // the occluder discs need no gather result: set here, before the fused region reads them
                occluders.px[at] = float(x.x), occluders.py[at] = float(x.y), occluders.pz[at] = float(x.z);
                occluders.nx[at] = float(n.x), occluders.ny[at] = float(n.y), occluders.nz[at] = float(n.z);
                const float radius = float(pointOccluderRadius[at]);
                occluders.r2[at] = radius * radius;
                ++at;
            }
        }
    }

    /// Stage 1: the running sums of every receiver over all VALs, group by group, and per group right
    /// after its sums are complete stage 2 and stage 3 (renormalisePoint, occlusionSetup, occludeSlots) and
    /// stage 4's per-point terms: all read only the group's own sums (and the occluder discs, set in
    /// placePoints()), so they need no join of their own and run on both cores instead of one.
    /// The threads take whole groups from a shared counter in planLayout()'s order (longest first), so the
    /// split follows the threads' actual progress: a worker that wakes late or loses its core to another
    /// process hands its groups to the others (a static split waited for it: the 2-thread wall time was
    /// ~0.8 ms above the critical path from thread CPU clocks). A group is computed whole by one thread in
    /// one order, so no result depends on who took it.
    void gather(const glm::dvec3& eye) {
        occlusionClock.begin();
        // the receivers are in coherent groups, in the order the threads take them, and the VAL blocks'
        // boxes are made (stage 0: buildValArrays)
        const std::size_t full = pointCount / cpu::kReceiverPadding;
        const std::size_t groups = receivers.padded / cpu::kReceiverPadding;
        const cpu::GatherParameters parameters{glossy, moments(), settings.skipHiddenBlocks};
        const std::size_t stride = receivers.padded;
        std::atomic<std::uint64_t> skipped{0};
        std::atomic<std::size_t> nextGroup{0};
        const bool areas = settings.lightSkin.nearFieldArea;
        if (areas) nearField.index(vals);
        parallelWorkers(*arena, regionClock, [&] {
            std::uint64_t n = 0;
            double occlusionMs = 0.0; // this thread's time in the occlusion kernel (stats)
            for (std::size_t sg = nextGroup.fetch_add(1, std::memory_order_relaxed); sg < groups;
                 sg = nextGroup.fetch_add(1, std::memory_order_relaxed)) {
                const std::size_t begin = sg * cpu::kReceiverPadding, end = begin + cpu::kReceiverPadding;
                for (std::size_t k = 0; k < cpu::kGatherSums; ++k)
                    for (std::size_t slot = begin; slot < end; ++slot) sums[k * stride + receivers.index[slot]] = 0.0f;
                // all VALs in one call (~850 KB of SoA for 19200 VALs stay in a core's L2); timed for the
                // next frames' order
                const auto before = Clock::now();
                n += cpu::gather(vals, 0, vals.padded, receivers, begin, end, parameters, sums.data(), stride);
                const double us = std::chrono::duration<double, std::micro>(Clock::now() - before).count();
                // per group of the sorted order, the least of its last kCostFrames frames' times: a time
                // slice lost to another process only ever adds to a group's time
                if (sg < full) {
                    const std::size_t g = layout[sg];
                    recentTimes[costFrame * groupCost.size() + g] = us;
                    double least = us;
                    for (std::size_t f = 0; f < kCostFrames; ++f) {
                        const double t = recentTimes[f * groupCost.size() + g];
                        if (t > 0.0) least = std::min(least, t);
                    }
                    groupCost[g] = least;
                }
                if (areas) nearField.apply(vals, receivers, begin, end, parameters, sums.data(), stride); // G12
                for (std::size_t slot = begin; slot < end; ++slot) {
                    const std::uint32_t i = receivers.index[slot];
                    if (i >= pointCount) continue; // padding
                    renormalisePoint(i, eye);
                    if (occlusion) occlusionSetup(i, slot);
                }
                if (occlusion) occlusionMs += occludeSlots(begin, end);
                for (std::size_t slot = begin; slot < end; ++slot)
                    if (receivers.index[slot] < pointCount) makePointTerms(receivers.index[slot]);
            }
            skipped += n;
            occlusionClock.add(occlusionMs);
        });
        pointTermsReady = true;
        const double blocks = double(vals.padded / cpu::kSumBlock) * double(receivers.padded); // x receivers
        stats.gatherBlocksSkipped = blocks > 0.0 ? double(skipped.load()) / blocks : 0.0;
    }

    /// The order in which the gather region's threads take the `full` whole groups of the sorted order
    /// (layout[slot group] = sorted group): with every group's time of the previous frames known
    /// (groupCost), longest first, so the last groups taken are short and the threads finish together
    /// (list scheduling, LPT); else bit-reversed order. With hidden blocks and unlit lanes skipped, groups
    /// differ several-fold in work. Decides only where and by whom a group is computed: no result depends
    /// on it.
    void planLayout(std::size_t full) {
        const bool known = full > 0 && std::all_of(groupCost.begin(), groupCost.begin() + std::ptrdiff_t(full),
                                                   [](double c) { return c > 0.0; });
        if (!known) {
            cpu::bitReversedLayout(std::span(layout).first(full));
            return;
        }
        for (std::size_t g = 0; g < full; ++g) layout[g] = std::uint32_t(g);
        std::sort(layout.begin(), layout.begin() + std::ptrdiff_t(full), [&](std::uint32_t a, std::uint32_t b) {
            return groupCost[a] != groupCost[b] ? groupCost[a] > groupCost[b] : a < b;
        });
    }

    double sum(std::size_t s, std::size_t i) const { return double(sums[s * receivers.padded + i]); }

    /// The second moments are gathered for S_o: occlusion, and the extended VPLs of guard G9.
    bool moments() const { return occlusion || settings.lightSkin.extendedVplHorizon; }

    /// eq. 7's sums of point i with the folded eps_l terms (as gather_renormalise.frag adds them).
    struct PointSums {
        glm::dvec3 L{0.0}, offset{0.0}, moment{0.0}, Ls{0.0}, offsetS{0.0};
        double W = 0.0, r2 = 0.0, Ws = 0.0, r2s = 0.0, momentS = 0.0;
    };
    PointSums pointSums(std::size_t i) const {
        const double eps = double(settings.lightSkin.epsilonL);
        const glm::dvec3 x = pointPosition[i];
        const double n = valSums[7];
        const glm::dvec3 sumL(valSums[0], valSums[1], valSums[2]), sumL2(valSums[4], valSums[5], valSums[6]);
        const glm::dvec3 epsOffset = eps * (sumL - n * x);
        const glm::dvec3 epsMoment =
            moments() ? eps * glm::max(sumL2 - 2.0 * x * sumL + n * x * x, glm::dvec3(0.0)) : glm::dvec3(0.0);
        const double glossyEps = glossy ? 1.0 : 0.0;
        PointSums p;
        p.L = {sum(0, i), sum(1, i), sum(2, i)};
        p.r2 = sum(3, i) + eps * valSums[3];
        p.offset = glm::dvec3(sum(4, i), sum(5, i), sum(6, i)) + epsOffset;
        p.W = sum(7, i) + eps * n;
        p.Ls = {sum(8, i), sum(9, i), sum(10, i)};
        p.r2s = sum(11, i) + glossyEps * eps * valSums[3];
        p.offsetS = glm::dvec3(sum(12, i), sum(13, i), sum(14, i)) + glossyEps * epsOffset;
        p.Ws = sum(15, i) + glossyEps * eps * n;
        p.moment = glm::dvec3(sum(16, i), sum(17, i), sum(18, i)) + epsMoment;
        p.momentS = sum(19, i) + glossyEps * (epsMoment.x + epsMoment.y + epsMoment.z);
        return p;
    }

    /// Stage 2 (eq. 8-11) of point i.
    void renormalisePoint(std::size_t i, const glm::dvec3& eye) {
        const PointSums p = pointSums(i);
        const glm::dvec3 x = pointPosition[i], nx = pointNormal[i];
        gatheredPeakD[i] = m::ls_peakChannel(p.L); // G10
        vplD[i] = m::ls_renormaliseDiffuse(p.L, p.offset, p.W, p.r2, p.moment, x, nx,
                                           settings.lightSkin.extendedVplHorizon ? 1.0 : 0.0);
        vplS[i] = m::ls_renormaliseGlossy(p.Ls, p.offsetS, p.Ws, p.r2s, p.momentS, x, nx, m::ls_toEye(x, eye),
                                          pointExponent[i]);
    }

    /// Stage 2 for every point, and stage 3's set-up if on: after the gather with a cut,
    /// which has its own threads; the flat gather does both inside its parallel region.
    void renormalise(const glm::dvec3& eye) {
        // ~0.1 us per point: threads pay off only for many points (a fork/join costs ~10 us idle,
        // a scheduler time slice when the cores are oversubscribed)
        const auto point = [&](std::size_t i) {
            renormalisePoint(i, eye);
            if (occlusion) occlusionSetup(i, i);
        };
        if (pointCount > 8192)
            parallelFor(*arena, regionClock, 0, pointCount, point, 256);
        else
            for (std::size_t i = 0; i < pointCount; ++i) point(i);
    }

    /// Stage 3 (section 3.3, eq. 14), per point: its targets (double) as a receiver, its disc as an
    /// occluder. Needs the point's VPLs (stage 2).
    /// Written at `slot` of the kernel's receiver arrays (the gather's slot of point i: the fused
    /// region runs the occlusion kernel over its own slots; each lane's sum is the same whichever
    /// lanes share its vector). The occluders (every point's disc) were set in placePoints().
    void occlusionSetup(std::size_t i, std::size_t slot) {
        cpu::OcclusionReceivers& r = occlusionReceivers;
        {
            const glm::dvec3 x = pointPosition[i], n = pointNormal[i];
            const glm::dvec3 t = m::ls_tangent(n), b = m::ls_binormal(n);
            const m::OcclusionTarget td = m::ls_occlusionTarget(x, n, t, b, vplD[i].position, vplD[i].sphereRadius);
            const m::OcclusionTarget ts = m::ls_occlusionTarget(x, n, t, b, vplS[i].position, vplS[i].sphereRadius);
            const std::size_t k = slot;
            r.px[k] = float(x.x), r.py[k] = float(x.y), r.pz[k] = float(x.z);
            r.nx[k] = float(n.x), r.ny[k] = float(n.y), r.nz[k] = float(n.z);
            r.tx[k] = float(t.x), r.ty[k] = float(t.y), r.tz[k] = float(t.z);
            r.bx[k] = float(b.x), r.by[k] = float(b.y), r.bz[k] = float(b.z);
            const auto setTarget = [&](const m::OcclusionTarget& o, float& cx, float& cy, float& half, float& invArea,
                                       float& dist, float& invRadius) {
                cx = float(o.centre.x);
                cy = float(o.centre.y);
                half = float(0.5 * o.side);
                invArea = o.area > m::kTinyArea ? float(1.0 / o.area) : 0.0f; // G7
                dist = float(o.distance);
                invRadius = float(1.0 / std::max(o.radius, 1.0e-30));
            };
            setTarget(td, r.dcx[k], r.dcy[k], r.dhalf[k], r.dinvArea[k], r.ddist[k], r.dinvRadius[k]);
            setTarget(ts, r.scx[k], r.scy[k], r.shalf[k], r.sinvArea[k], r.sdist[k], r.sinvRadius[k]);
        }
    }

    /// Stage 3 for the slots [begin, end) set up by occlusionSetup(): the occluder sums (SIMD) into
    /// occlusionSlotD/S, then to each point's entry of occlusionD/S. Returns the time spent here, ms
    /// (steady clock: a thread CPU clock read is a system call, ~0.8 us here, and this runs per group).
    double occludeSlots(std::size_t begin, std::size_t end) {
        const auto start = Clock::now();
        occlusionSkipped += cpu::occlusion(occlusionReceivers, begin, end, occluders, glossy, occlusionSlotD.data(),
                                           occlusionSlotS.data(), settings.skipHiddenBlocks);
        for (std::size_t slot = begin; slot < end; ++slot) {
            const std::uint32_t i = receivers.index[slot];
            if (i >= pointCount) continue;
            occlusionD[i] = occlusionSlotD[slot];
            occlusionS[i] = occlusionSlotS[slot];
        }
        return millisecondsSince(start);
    }

    /// Stage 3's sums over all occluders after the gather with a cut (its points in their own
    /// order, slot = point: occlusionSetup(i, i)); the flat gather runs occludeSlots() in its region.
    void occlude() {
        cpu::OcclusionReceivers& r = occlusionReceivers;
        parallelRanges(*arena, regionClock, r.padded, [&](std::size_t begin, std::size_t end) {
            occlusionSkipped += cpu::occlusion(r, begin, end, occluders, glossy, occlusionD.data(), occlusionS.data(),
                                               settings.skipHiddenBlocks);
        });
    }

    void makePointTerms(std::size_t s) {
        const double keepD = occlusion ? 1.0 - std::clamp(double(occlusionD[s]), 0.0, 1.0) : 1.0;
        const double keepS = occlusion ? 1.0 - std::clamp(double(occlusionS[s]), 0.0, 1.0) : 1.0;
        const glm::dvec3 od = vplD[s].position - pointPosition[s], os = vplS[s].position - pointPosition[s];
        PointTerms& t = pointTerms[s];
        t.minDD = glm::dot(od, od) + vplD[s].r2;
        t.minDS = glm::dot(os, os) + vplS[s].r2;
        t.cap = gatheredPeakD[s] * keepD;
        t.diffuse = glm::dvec4(vplD[s].radiance * keepD, vplD[s].r2);
        t.diffusePosition =
            glm::dvec4(vplD[s].position, settings.lightSkin.extendedVplHorizon ? vplD[s].sphereRadius : 0.0);
        t.glossy = glm::dvec4(vplS[s].radiance * keepS, vplS[s].r2);
        t.glossyPosition = glm::dvec4(vplS[s].position, 0.0);
    }

    /// Stage 4 (eq. 12-13) per vertex, with the occlusion attenuation L'' (1 - o).
    void interpolate(std::span<const MeshInstance> instances, const RealDepthView& realDepth) {
        // G11: which sparse points lie under the real surface (all 0 without a depth map or the rule).
        const std::span<std::uint8_t> buriedFlags = std::span(pointBuried).first(pointCount);
        if (settings.lightSkin.buriedSparsePoints && realDepth.data != nullptr)
            markBuriedInto(std::span<const glm::dvec3>(pointPosition).first(pointCount), realDepth, buriedFlags);
        else
            std::fill(buriedFlags.begin(), buriedFlags.end(), std::uint8_t(0));
        for (std::size_t mesh = 0; mesh < instances.size(); ++mesh) {
            meshTransforms[mesh] = glm::dmat4(instances[mesh].world_T_model);
            meshNormalMatrices[mesh] = glm::transpose(glm::inverse(glm::dmat3(meshTransforms[mesh])));
            meshSimilar[mesh] = isSimilarity(glm::dmat3(meshTransforms[mesh])) ? 1 : 0;
        }
        const bool capOn = settings.lightSkin.vertexIrradianceCap;
        if (!pointTermsReady) // the gather with a cut; the flat gather's threads made them
            for (std::size_t i = 0; i < pointCount; ++i) makePointTerms(i);
        // one region over every mesh's vertices (one join instead of one per mesh)
        {
            parallelFor(
                *arena, regionClock, 0, vertexCount,
                [&](std::size_t v) {
                    const std::size_t mesh =
                        std::size_t(std::upper_bound(vertexOffsets.begin(), vertexOffsets.end(), std::uint32_t(v)) -
                                    vertexOffsets.begin() - 1);
                    const glm::dmat4& transform = meshTransforms[mesh];
                    const glm::dmat3& normalMatrix = meshNormalMatrices[mesh];
                    const glm::dvec3 p(transform * glm::dvec4(modelVertexPositions[v], 1.0));
                    const auto& list = neighbours[v];
                    bool anyBuried = false;
                    for (const std::uint32_t i : list) anyBuried = anyBuried || buriedFlags[i] != 0;
                    m::VertexWeights weights;
                    if (meshSimilar[mesh] != 0 && !anyBuried) {
                        std::copy_n(modelWeights[v].begin(), kVertexNeighbours, weights.w);
                    } else {
                        const glm::dvec3 nv = glm::normalize(normalMatrix * modelVertexNormals[v]);
                        double dist[kVertexNeighbours], cosN[kVertexNeighbours];
                        bool unique[kVertexNeighbours], buried[kVertexNeighbours];
                        for (std::size_t j = 0; j < std::size_t(kVertexNeighbours); ++j) {
                            dist[j] = glm::length(p - pointPosition[list[j]]);
                            cosN[j] = glm::dot(nv, pointNormal[list[j]]);
                            unique[j] = j == 0 || list[j] != list[j - 1];
                            buried[j] = buriedFlags[list[j]] != 0; // G11
                        }
                        weights = m::ls_vertexWeightsAboveSurface(dist, cosN, unique, buried);
                    }
                    glm::dvec4 diffuse(0.0), diffusePosition(0.0), glossyRadiance(0.0), glossyPosition(0.0);
                    double minDD = std::numeric_limits<double>::max(), minDS = minDD; // G8
                    double cap = 0.0;                                                 // G10
                    for (std::size_t j = 0; j < std::size_t(kVertexNeighbours); ++j) {
                        const double w = weights.w[j];
                        if (w == 0.0) continue;
                        const PointTerms& t = pointTerms[list[j]];
                        minDD = std::min(minDD, t.minDD);
                        minDS = std::min(minDS, t.minDS);
                        cap = std::max(cap, t.cap); // G10
                        diffuse += w * t.diffuse;
                        diffusePosition += w * t.diffusePosition; // G9
                        glossyRadiance += w * t.glossy;
                        glossyPosition += w * t.glossyPosition;
                    }
                    if (settings.lightSkin.vertexDistanceFloor) {
                        diffuse.w = m::ls_vertexR2Floor(diffuse.w, p, glm::dvec3(diffusePosition), minDD);
                        glossyRadiance.w = m::ls_vertexR2Floor(glossyRadiance.w, p, glm::dvec3(glossyPosition), minDS);
                    }
                    glm::vec4* out = &vertexVpls[4 * v];
                    out[0] = glm::vec4(diffuse);
                    out[1] = glm::vec4(diffusePosition);
                    out[2] = glm::vec4(glossyRadiance);
                    out[3] = glm::vec4(glm::dvec3(glossyPosition), capOn ? cap : -1.0);
                },
                256); // ~25 ns per vertex: ~6 us per chunk
        }
    }

    void chooseChannels(std::span<const MeshInstance> instances) {
        const LightSkinSettings& s = settings.lightSkin;
        glossy = s.glossy;
        occlusion = s.occlusion;
        if (!s.adaptive) return;
        if (glossy && std::none_of(instances.begin(), instances.end(),
                                   [](const MeshInstance& i) { return i.material.hasSpecular(); }))
            glossy = false;
        if (occlusion && instances.size() == 1 && convex[0]) occlusion = false;
    }
};

CpuLightSkin::CpuLightSkin()
    : impl_(std::make_unique<Impl>()) {}
CpuLightSkin::~CpuLightSkin() = default;

std::string cpuSimdTarget() { return cpu::simdTargetName(); }
std::vector<std::string> cpuSimdTargets() { return core::simdTargets(); }
double cpuFmaPeakGflops(double milliseconds) {
    float sink = 0.0f;
    double flops = 0.0;
    const double start = processCpuMs();
    double elapsed = 0.0;
    while ((elapsed = processCpuMs() - start) < milliseconds) flops += cpu::fmaChains(100000, &sink);
    return std::isfinite(sink) ? flops / (elapsed * 1e6) : 0.0;
}
void cpuLobePow(std::span<const float> cosGamma, std::span<const float> exponent, std::span<float> out) {
    LIGHTSKIN_ASSERT(cosGamma.size() == exponent.size() && out.size() == cosGamma.size(),
                     "lightskin::gi::cpuLobePow(): the spans differ in size");
    // the kernel takes whole vectors: pad through small fixed chunks (test use, not per frame)
    constexpr std::size_t kChunk = 1024;
    static_assert(kChunk % cpu::kReceiverPadding == 0);
    std::array<float, kChunk> c{}, k{}, o{};
    for (std::size_t first = 0; first < out.size(); first += kChunk) {
        const std::size_t n = std::min(kChunk, out.size() - first);
        c.fill(0.0f);
        k.fill(1.0f);
        std::copy_n(cosGamma.begin() + std::ptrdiff_t(first), n, c.begin());
        std::copy_n(exponent.begin() + std::ptrdiff_t(first), n, k.begin());
        cpu::lobePow(c.data(), k.data(), o.data(), padReceivers(n));
        std::copy_n(o.begin(), n, out.begin() + std::ptrdiff_t(first));
    }
}
void setCpuSimdTarget(const std::string& name) { core::restrictSimdTarget(name); }

std::unique_ptr<CpuLightSkin> CpuLightSkin::create(const CpuLightSkinSettings& settings, SparsePointProvider provider) {
    LIGHTSKIN_ASSERT(bool(provider), "lightskin::gi::CpuLightSkin::create(): a sparse point provider is required");
    if (settings.threads < 0)
        throw Error("CpuLightSkinSettings.threads", std::nullopt,
                    "must be >= 0 (0 = all hardware threads), got " + std::to_string(settings.threads));
    std::unique_ptr<CpuLightSkin> technique(new CpuLightSkin());
    Impl& impl = *technique->impl_;
    impl.settings = settings;
    impl.createArena();
    impl.provider = std::move(provider);
    impl.shade =
        impl.library.buildProgram({{GL_VERTEX_SHADER, "gather_shade.vert"}, {GL_FRAGMENT_SHADER, "gather_shade.frag"}});
    impl.shadeFramebuffer = gl::Framebuffer::create();
    impl.timer = gl::GpuStageTimer::create(2);
    impl.stats.simdTarget = cpu::simdTargetName();
    impl.reserveVals(settings.lightSkin.valCapacity);
    return technique;
}

const CpuLightSkinSettings& CpuLightSkin::settings() const noexcept { return impl_->settings; }
int CpuLightSkin::threads() const noexcept { return impl_->settings.threads; }

TechniqueCapabilities CpuLightSkin::capabilities() const noexcept {
    // Stages 0-4 are CPU wall times; the shading is the GL timer's.
    static constexpr CpuStageLabel kStages[] = {{"upload", "gi upload"},
                                                {"gather", "gi gather"},
                                                {"normalisation", "gi normalisation"},
                                                {"occlusion", "gi occlusion"},
                                                {"interpolation", "gi interpolation"}};
    return {.glossy = true, .occlusion = true, .sparsePoints = true, .vertexVpls = true, .cpuStages = kStages};
}
void CpuLightSkin::setSettings(const CpuLightSkinSettings& settings) {
    if (settings.threads < 0)
        throw Error("CpuLightSkinSettings.threads", std::nullopt,
                    "must be >= 0, got " + std::to_string(settings.threads));
    const bool threadsChanged = settings.threads != impl_->settings.threads;
    impl_->settings = settings;
    if (threadsChanged) impl_->createArena();
}
const CpuLightSkinStats& CpuLightSkin::lastStats() const noexcept { return impl_->stats; }
const std::vector<std::uint32_t>& CpuLightSkin::vertexOffsets() const noexcept { return impl_->vertexOffsets; }

void CpuLightSkin::prepare(std::span<const MeshInstance> instances) {
    Impl& impl = *impl_;
    impl.sparse.clear();
    impl.sparseOffsets.clear();
    impl.vertexOffsets.clear();
    impl.convex.clear();
    impl.modelVertexPositions.clear();
    impl.modelVertexNormals.clear();
    impl.neighbours.clear();
    impl.modelWeights.clear();
    impl.pointCount = 0;
    impl.vertexCount = 0;
    for (const MeshInstance& instance : instances) {
        LIGHTSKIN_ASSERT(instance.mesh != nullptr, "lightskin::gi::CpuLightSkin::prepare(): instance without mesh");
        SparsePointSet set = impl.provider(instance);
        const std::string source = "mesh " + std::to_string(instance.meshId);
        if (set.points.empty()) throw Error(source, std::nullopt, "the sparse point provider returned no points");
        if (set.vertexNeighbours.size() != instance.mesh->vertexCount())
            throw Error(source, std::nullopt,
                        "sparse point set has " + std::to_string(set.vertexNeighbours.size()) +
                            " neighbour lists for " + std::to_string(instance.mesh->vertexCount()) + " vertices");
        for (const auto& list : set.vertexNeighbours)
            for (std::uint32_t index : list)
                if (index >= set.points.size()) throw Error(source, std::nullopt, "neighbour index out of range");
        impl.sparseOffsets.push_back(impl.pointCount);
        impl.vertexOffsets.push_back(impl.vertexCount);
        const TriangleMesh& mesh = *instance.mesh;
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
            impl.modelVertexPositions.emplace_back(mesh.positions[v]);
            impl.modelVertexNormals.emplace_back(mesh.normals[v]);
            auto list = set.vertexNeighbours[v];
            for (auto& index : list) index += impl.pointCount;
            impl.neighbours.push_back(list);
        }
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v)
            impl.modelWeights.push_back(modelVertexWeights(mesh, v, set));
        impl.pointCount += std::uint32_t(set.points.size());
        impl.vertexCount += std::uint32_t(mesh.vertexCount());
        impl.convex.push_back(detail::convexForOcclusion(set));
        impl.sparse.push_back(std::move(set));
    }
    // No instance (no virtual content) is valid: the arrays below are empty, computeVpls() does nothing and
    // shadeVpls() clears the target, until the next prepare().
    const std::size_t padded = padReceivers(impl.pointCount);
    impl.pointPosition.assign(impl.pointCount, glm::dvec3(0.0));
    impl.pointNormal.assign(impl.pointCount, glm::dvec3(0.0, 0.0, 1.0));
    impl.pointExponent.assign(impl.pointCount, 1.0);
    impl.pointOccluderRadius.assign(impl.pointCount, 0.0);
    impl.receivers.resize(padded);
    impl.sums.assign(cpu::kGatherSums * padded, 0.0f);
    impl.groupCost.assign(padded / cpu::kReceiverPadding, 0.0);
    impl.recentTimes.assign(Impl::kCostFrames * (padded / cpu::kReceiverPadding), 0.0);
    impl.layout.assign(padded / cpu::kReceiverPadding, 0);
    impl.vplD.assign(impl.pointCount, m::Vpl{});
    impl.gatheredPeakD.assign(impl.pointCount, 0.0);
    impl.pointBuried.assign(impl.pointCount, 0);
    impl.vplS.assign(impl.pointCount, m::Vpl{});
    impl.occlusionReceivers.resize(padded);
    impl.occluders.resize(impl.pointCount);
    impl.occlusionD.assign(padded, 0.0f);
    impl.occlusionS.assign(padded, 0.0f);
    impl.occlusionSlotD.assign(padded, 0.0f);
    impl.occlusionSlotS.assign(padded, 0.0f);
    impl.vertexVpls.assign(std::size_t(impl.vertexCount) * 4, glm::vec4(0.0f));
    impl.pointTerms.assign(impl.pointCount, Impl::PointTerms{});
    impl.meshTransforms.assign(instances.size(), glm::dmat4(1.0));
    impl.meshNormalMatrices.assign(instances.size(), glm::dmat3(1.0));
    impl.meshSimilar.assign(instances.size(), 0);
    impl.vertexVplBuffer = gl::Buffer::create(GLsizeiptr(std::max<std::uint32_t>(impl.vertexCount, 1)) * 64, nullptr,
                                              GL_DYNAMIC_STORAGE_BIT);
    if (impl.pointCount == 0) {
        log::info("lightskin-cpu: prepared no instance: no virtual content, GI idle");
        return;
    }
    log::info("lightskin-cpu: prepared " + std::to_string(instances.size()) + " instance(s), " +
              std::to_string(impl.pointCount) + " sparse points, " + std::to_string(impl.vertexCount) + " vertices, " +
              impl.stats.simdTarget + ", " + std::to_string(impl.threadCount()) + " thread(s)");
}

void CpuLightSkin::computeVpls(std::span<const VirtualAreaLight> lights, std::span<const MeshInstance> instances,
                               const glm::vec3& cameraPositionWorld, const CpuValPixelKeys& pixels,
                               const RealDepthView& realDepth) {
    Impl& impl = *impl_;
    LIGHTSKIN_ASSERT(instances.size() == impl.sparse.size(),
                     "lightskin::gi::CpuLightSkin::computeVpls(): instances differ from prepare()");
    for (std::size_t i = 0; i < instances.size(); ++i)
        LIGHTSKIN_ASSERT(instances[i].mesh != nullptr &&
                             instances[i].mesh->vertexCount() == impl.sparse[i].vertexNeighbours.size(),
                         "lightskin::gi::CpuLightSkin::computeVpls(): instance mesh differs from prepare()");
    CpuLightSkinStats& stats = impl.stats;
    if (impl.pointCount == 0) { // prepared without virtual content: nothing to light
        const std::string simdTarget = stats.simdTarget;
        stats = {};
        stats.simdTarget = simdTarget;
        return;
    }
    impl.chooseChannels(instances);
    const glm::dvec3 eye(cameraPositionWorld);

    const double cpuStart = processCpuMs(), callerStart = threadCpuMs();
    impl.regionClock.excessMs = 0.0;
    impl.pointTermsReady = false;
    impl.occlusionSkipped = 0;
    auto start = Clock::now();
    const LightSkinSettings& lightSkin = impl.settings.lightSkin;
    const double treeThreshold = lights.size() >= lightSkin.valTreeMinVals ? double(lightSkin.valTreeThreshold) : 0.0;
    impl.buildValArrays(lights, instances, eye, treeThreshold <= 0.0);
    stats.uploadMs = impl.readbackMs + millisecondsSince(start);
    impl.readbackMs = 0.0;

    start = Clock::now();
    double cpu = processCpuMs();
    if (treeThreshold > 0.0) {
        impl.treeCut.gather(lights, std::span(impl.pointPosition).first(impl.pointCount),
                            std::span(impl.pointNormal).first(impl.pointCount),
                            std::span(impl.pointExponent).first(impl.pointCount), eye,
                            double(impl.settings.lightSkin.cParameter), impl.glossy, impl.moments(),
                            impl.settings.lightSkin.nearFieldArea, treeThreshold, impl.threadCount(), impl.sums.data(),
                            impl.receivers.padded, cpu::ValTreeImage{pixels.keys, pixels.width, pixels.height});
        stats.valTreeCutPerPoint =
            double(impl.treeCut.stats().taken) / double(std::max<std::uint32_t>(impl.pointCount, 1));
        stats.valTreeQuadtree = impl.treeCut.stats().quadtree;
        stats.gatherBlocksSkipped = 0.0;
    } else {
        impl.gather(eye); // with stage 2 and stage 3's set-up in its threads
        stats.valTreeCutPerPoint = 0.0;
        stats.valTreeQuadtree = false;
    }
    stats.gatherMs = millisecondsSince(start);
    stats.gatherCpuMs = processCpuMs() - cpu;

    start = Clock::now();
    if (treeThreshold > 0.0) impl.renormalise(eye);
    stats.normalisationMs = millisecondsSince(start);

    start = Clock::now();
    cpu = processCpuMs();
    if (!impl.occlusion) {
        std::fill(impl.occlusionD.begin(), impl.occlusionD.end(), 0.0f);
        std::fill(impl.occlusionS.begin(), impl.occlusionS.end(), 0.0f);
    } else if (treeThreshold > 0.0) {
        impl.occlude();
    }
    stats.occlusionMs = millisecondsSince(start);
    stats.occlusionCpuMs = processCpuMs() - cpu;
    {
        const double pairs = double(impl.occluders.count) * double(impl.occlusionReceivers.padded);
        stats.occlusionPairsSkipped =
            impl.occlusion && pairs > 0.0 ? double(impl.occlusionSkipped.load()) / pairs : 0.0;
    }
    if (impl.occlusion && treeThreshold <= 0.0) { // ran inside the gather's region: its threads' time there
        double occlusionCpu = 0.0;
        for (const double ms : impl.occlusionClock.slotMs) occlusionCpu += ms;
        stats.occlusionCpuMs = occlusionCpu;
        stats.gatherCpuMs -= occlusionCpu;
    }

    start = Clock::now();
    impl.interpolate(instances, realDepth);
    stats.interpolationMs = millisecondsSince(start);
    stats.stagesCpuMs = processCpuMs() - cpuStart;
    stats.criticalPathCpuMs = threadCpuMs() - callerStart + impl.regionClock.excessMs;

    stats.vals = impl.vals.count;
    stats.points = impl.pointCount;
    stats.vertices = impl.vertexCount;
    stats.glossy = impl.glossy;
    stats.occlusion = impl.occlusion;
}

void CpuLightSkin::render(const ValSetView& lights, std::span<const MeshInstance> instances, const GBufferView& gbuffer,
                          const ViewParameters& view, std::uint32_t targetTexture) {
    Impl& impl = *impl_;
    const auto start = Clock::now();
    impl.reserveVals(lights.count);
    if (lights.count > 0)
        glGetNamedBufferSubData(lights.buffer, 0, GLsizeiptr(lights.count) * GLsizeiptr(sizeof(VirtualAreaLight)),
                                impl.staging.data());
    // pixel keys only matter to the gather with a cut (the quadtree); else they are not read back
    CpuValPixelKeys pixels;
    if (impl.settings.lightSkin.valTreeThreshold > 0.0f && lights.count >= impl.settings.lightSkin.valTreeMinVals &&
        lights.keys != 0 && lights.keyWidth > 0 && lights.count > 0) {
        impl.stagingKeys.resize(lights.count);
        glGetNamedBufferSubData(lights.keys, 0, GLsizeiptr(lights.count) * 4, impl.stagingKeys.data());
        pixels = {impl.stagingKeys, lights.keyWidth, lights.keyCount / lights.keyWidth};
    }
    impl.readbackMs = millisecondsSince(start);
    renderCpuVals(std::span<const VirtualAreaLight>(impl.staging.data(), lights.count), instances, gbuffer, view,
                  targetTexture, pixels);
}

void CpuLightSkin::renderCpuVals(std::span<const VirtualAreaLight> lights, std::span<const MeshInstance> instances,
                                 const GBufferView& gbuffer, const ViewParameters& view, std::uint32_t targetTexture,
                                 const CpuValPixelKeys& pixels) {
    computeVpls(lights, instances, view.cameraPositionWorld, pixels, view.realDepth);
    shadeVpls(instances, gbuffer, view, targetTexture);
}

void CpuLightSkin::shadeVpls(std::span<const MeshInstance> instances, const GBufferView& gbuffer,
                             const ViewParameters& view, std::uint32_t targetTexture) {
    Impl& impl = *impl_;
    const auto uploadStart = Clock::now();
    if (impl.vertexCount > 0)
        glNamedBufferSubData(impl.vertexVplBuffer.id(), 0, GLsizeiptr(impl.vertexVpls.size() * sizeof(glm::vec4)),
                             impl.vertexVpls.data());
    impl.stats.interpolationMs += millisecondsSince(uploadStart);

    const auto shadeStart = Clock::now();
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_BLEND);
    impl.timer.beginFrame();
    impl.timer.begin("shading");
    detail::shadeVertexVpls(impl.shade, impl.vertexVplBuffer.id(), impl.vertexOffsets, instances, gbuffer, view,
                            impl.settings.lightSkin.shadingPositionTolerance, impl.glossy, targetTexture,
                            impl.shadeFramebuffer);
    impl.timer.end();
    impl.stats.shadingMs = millisecondsSince(shadeStart);
    impl.timer.collect(impl.stageTimes);
}

void CpuLightSkin::lastStageTimes(std::vector<gl::StageTime>& out) const {
    const CpuLightSkinStats& s = impl_->stats;
    out.resize(5);
    const std::pair<const char*, double> cpuStages[5] = {{"upload", s.uploadMs},
                                                         {"gather", s.gatherMs},
                                                         {"normalisation", s.normalisationMs},
                                                         {"occlusion", s.occlusionMs},
                                                         {"interpolation", s.interpolationMs}};
    for (std::size_t i = 0; i < 5; ++i) {
        out[i].name = cpuStages[i].first;
        out[i].milliseconds = cpuStages[i].second;
    }
    for (const gl::StageTime& t : impl_->stageTimes) out.push_back(t);
}

void CpuLightSkin::readGatherSums(std::vector<glm::vec4>& out) const {
    const Impl& impl = *impl_;
    out.assign(std::size_t(impl.pointCount) * 5, glm::vec4(0.0f));
    for (std::size_t i = 0; i < impl.pointCount; ++i) {
        const Impl::PointSums p = impl.pointSums(i);
        glm::vec4* g = &out[5 * i];
        g[0] = glm::vec4(glm::dvec4(p.L, p.r2));
        g[1] = glm::vec4(glm::dvec4(p.offset, p.W));
        g[2] = glm::vec4(glm::dvec4(p.Ls, p.r2s));
        g[3] = glm::vec4(glm::dvec4(p.offsetS, p.Ws));
        g[4] = glm::vec4(glm::dvec4(p.moment, impl.glossy ? p.momentS : 0.0));
    }
}

void CpuLightSkin::readSparseVpls(std::vector<glm::vec4>& out) const {
    const Impl& impl = *impl_;
    out.assign(std::size_t(impl.pointCount) * 4, glm::vec4(0.0f));
    for (std::size_t i = 0; i < impl.pointCount; ++i) {
        const m::Vpl& d = impl.vplD[i];
        const m::Vpl& s = impl.vplS[i];
        out[4 * i + 0] = glm::vec4(glm::dvec4(d.radiance, d.r2));
        out[4 * i + 1] = glm::vec4(glm::dvec4(d.position, d.sphereRadius));
        out[4 * i + 2] = glm::vec4(glm::dvec4(s.radiance, s.r2));
        out[4 * i + 3] = glm::vec4(glm::dvec4(s.position, s.sphereRadius));
    }
}

void CpuLightSkin::readOcclusion(std::vector<glm::vec4>& out) const {
    const Impl& impl = *impl_;
    out.assign(impl.pointCount, glm::vec4(0.0f));
    for (std::size_t i = 0; i < impl.pointCount; ++i)
        out[i] = glm::vec4(impl.occlusionD[i], impl.occlusionS[i], 0.0f, 0.0f);
}

void CpuLightSkin::readVertexVpls(std::vector<glm::vec4>& out) const { out = impl_->vertexVpls; }

} // namespace lightskin::gi
