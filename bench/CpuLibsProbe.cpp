// lightskin_bench_cpu_libs: the library choices of the CPU GI backend, measured side by
// side in one run (docs/bench/history/cpu-backend.md, "Decision: Highway stays"):
//  1. SIMD: Google Highway against xsimd on the diffuse gather kernel of CpuGatherKernels.cpp
//     (eq. 3-4, 7; the same operations in the same order: 1/sqrt estimate + one Newton step, a
//     division for g, fused multiply-adds, 16-VAL summation blocks), one thread;
//  2. threads: OpenMP against oneTBB running the same (Highway) kernel over the same contiguous
//     receiver ranges (static split: results independent of the thread count in both).
// Setup: the Kinect case, 1024 receivers x 19200 VALs (a 640x480 depth map at VAL stride 4), 2048-VAL
// tiles. Built with -O3 -march=native (this program only, like lightskin_bench_peak) so that both
// SIMD libraries compile for the machine's widest vectors statically; a benchmark, never a test.
#include <hwy/highway.h>
#include <omp.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
// Debian 12's xsimd 8.1.0 names a non-existent intrinsic in its AVX-512 rsqrt (_mm512_rsqrt23_ps;
// fixed upstream as _mm512_rsqrt14_ps), which fails to compile wherever AVX-512 is enabled.
#include <immintrin.h>
#define _mm512_rsqrt23_ps _mm512_rsqrt14_ps
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <random>
#include <string>
#include <vector>
#include <xsimd/xsimd.hpp>

namespace {

namespace hn = hwy::HWY_NAMESPACE;

constexpr std::size_t kReceivers = 1024, kVals = 19200, kBlock = 16, kTile = 2048, kSums = 8;
constexpr float kTiny = 1e-12f; // kTinyLength2 of lightskin_math.glsl

struct Vals {
    std::vector<float> px, py, pz, nx, ny, nz, r2, cr2, fr, fg, fb;
};
struct Receivers {
    std::vector<float> px, py, pz, nx, ny, nz;
};

/// VALs on a wall and receivers on a sphere in front of it (positions in metres).
void makeScene(Vals& v, Receivers& r) {
    std::mt19937 rng(18);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (auto* a : {&v.px, &v.py, &v.pz, &v.nx, &v.ny, &v.nz, &v.r2, &v.cr2, &v.fr, &v.fg, &v.fb}) a->resize(kVals);
    for (std::size_t j = 0; j < kVals; ++j) {
        v.px[j] = 2.0f * u(rng), v.py[j] = 1.5f * u(rng), v.pz[j] = 3.0f + 0.1f * u(rng);
        const float nx = 0.2f * u(rng), ny = 0.2f * u(rng), nz = -1.0f;
        const float l = std::sqrt(nx * nx + ny * ny + nz * nz);
        v.nx[j] = nx / l, v.ny[j] = ny / l, v.nz[j] = nz / l;
        v.r2[j] = 1e-4f * (1.0f + 0.5f * u(rng));
        v.cr2[j] = 1e-3f * v.r2[j];
        v.fr[j] = 0.5f + 0.4f * u(rng), v.fg[j] = 0.5f + 0.4f * u(rng), v.fb[j] = 0.5f + 0.4f * u(rng);
    }
    for (auto* a : {&r.px, &r.py, &r.pz, &r.nx, &r.ny, &r.nz}) a->resize(kReceivers);
    for (std::size_t i = 0; i < kReceivers; ++i) {
        float x = u(rng), y = u(rng), z = u(rng);
        const float l = std::max(std::sqrt(x * x + y * y + z * z), 1e-3f);
        x /= l, y /= l, z /= l;
        r.px[i] = 0.3f * x, r.py[i] = 0.3f * y, r.pz[i] = 1.5f + 0.3f * z;
        r.nx[i] = x, r.ny[i] = y, r.nz[i] = z;
    }
}

// ---- Highway (static target: the -march=native one) ----
using HD = hn::ScalableTag<float>;
using HV = hn::Vec<HD>;

HWY_INLINE HV hwyDot(HV ax, HV ay, HV az, HV bx, HV by, HV bz) {
    return hn::MulAdd(az, bz, hn::MulAdd(ay, by, hn::Mul(ax, bx)));
}

void hwyGather(const Vals& v, std::size_t valBegin, std::size_t valEnd, const Receivers& r, std::size_t i,
               float* sums) {
    const HD d;
    const HV zero = hn::Zero(d), tiny = hn::Set(d, kTiny);
    const HV x = hn::LoadU(d, &r.px[i]), y = hn::LoadU(d, &r.py[i]), z = hn::LoadU(d, &r.pz[i]);
    const HV nx = hn::LoadU(d, &r.nx[i]), ny = hn::LoadU(d, &r.ny[i]), nz = hn::LoadU(d, &r.nz[i]);
    for (std::size_t first = valBegin; first < valEnd; first += kBlock) {
        HV eR = zero, eG = zero, eB = zero, r2D = zero, oDx = zero, oDy = zero, oDz = zero, wDs = zero;
        for (std::size_t j = first; j < first + kBlock; ++j) {
            const HV ox = hn::Sub(hn::Set(d, v.px[j]), x), oy = hn::Sub(hn::Set(d, v.py[j]), y),
                     oz = hn::Sub(hn::Set(d, v.pz[j]), z);
            const HV r2 = hn::Set(d, v.r2[j]);
            const HV d2 = hwyDot(ox, oy, oz, ox, oy, oz);
            const HV a = hn::Max(hn::Add(d2, hn::Set(d, v.cr2[j])), tiny);
            const HV e = hn::ApproximateReciprocalSqrt(a);
            const HV inv = hn::Mul(e, hn::NegMulAdd(hn::Mul(a, hn::Set(d, 0.5f)), hn::Mul(e, e), hn::Set(d, 1.5f)));
            const HV tx = hn::Mul(ox, inv), ty = hn::Mul(oy, inv), tz = hn::Mul(oz, inv);
            const HV cosI = hn::Max(hwyDot(nx, ny, nz, tx, ty, tz), zero);
            const HV cosJ = hn::Max(
                hn::Neg(hwyDot(hn::Set(d, v.nx[j]), hn::Set(d, v.ny[j]), hn::Set(d, v.nz[j]), tx, ty, tz)), zero);
            const HV g = hn::Div(cosJ, hn::Max(hn::Add(r2, d2), tiny));
            const HV wD = hn::Mul(hn::Mul(r2, g), cosI);
            const HV gCos = hn::Mul(g, cosI);
            eR = hn::MulAdd(hn::Set(d, v.fr[j]), gCos, eR);
            eG = hn::MulAdd(hn::Set(d, v.fg[j]), gCos, eG);
            eB = hn::MulAdd(hn::Set(d, v.fb[j]), gCos, eB);
            r2D = hn::MulAdd(r2, wD, r2D);
            oDx = hn::MulAdd(ox, wD, oDx);
            oDy = hn::MulAdd(oy, wD, oDy);
            oDz = hn::MulAdd(oz, wD, oDz);
            wDs = hn::Add(wDs, wD);
        }
        const HV block[kSums] = {eR, eG, eB, r2D, oDx, oDy, oDz, wDs};
        for (std::size_t s = 0; s < kSums; ++s) {
            float* p = sums + s * kReceivers + i;
            hn::StoreU(hn::Add(hn::LoadU(d, p), block[s]), d, p);
        }
    }
}

// ---- xsimd (default architecture: the -march=native one) ----
using XB = xsimd::batch<float>;

inline XB xDot(XB ax, XB ay, XB az, XB bx, XB by, XB bz) { return xsimd::fma(az, bz, xsimd::fma(ay, by, ax * bx)); }

void xsimdGather(const Vals& v, std::size_t valBegin, std::size_t valEnd, const Receivers& r, std::size_t i,
                 float* sums) {
    const XB zero(0.0f), tiny(kTiny);
    const XB x = XB::load_unaligned(&r.px[i]), y = XB::load_unaligned(&r.py[i]), z = XB::load_unaligned(&r.pz[i]);
    const XB nx = XB::load_unaligned(&r.nx[i]), ny = XB::load_unaligned(&r.ny[i]), nz = XB::load_unaligned(&r.nz[i]);
    for (std::size_t first = valBegin; first < valEnd; first += kBlock) {
        XB eR = zero, eG = zero, eB = zero, r2D = zero, oDx = zero, oDy = zero, oDz = zero, wDs = zero;
        for (std::size_t j = first; j < first + kBlock; ++j) {
            const XB ox = XB(v.px[j]) - x, oy = XB(v.py[j]) - y, oz = XB(v.pz[j]) - z;
            const XB r2(v.r2[j]);
            const XB d2 = xDot(ox, oy, oz, ox, oy, oz);
            const XB a = xsimd::max(d2 + XB(v.cr2[j]), tiny);
            const XB e = xsimd::rsqrt(a); // the estimate (rsqrt14 / rsqrtps), as Highway's
            const XB inv = e * xsimd::fnma(a * XB(0.5f), e * e, XB(1.5f));
            const XB tx = ox * inv, ty = oy * inv, tz = oz * inv;
            const XB cosI = xsimd::max(xDot(nx, ny, nz, tx, ty, tz), zero);
            const XB cosJ = xsimd::max(-xDot(XB(v.nx[j]), XB(v.ny[j]), XB(v.nz[j]), tx, ty, tz), zero);
            const XB g = cosJ / xsimd::max(r2 + d2, tiny);
            const XB wD = (r2 * g) * cosI;
            const XB gCos = g * cosI;
            eR = xsimd::fma(XB(v.fr[j]), gCos, eR);
            eG = xsimd::fma(XB(v.fg[j]), gCos, eG);
            eB = xsimd::fma(XB(v.fb[j]), gCos, eB);
            r2D = xsimd::fma(r2, wD, r2D);
            oDx = xsimd::fma(ox, wD, oDx);
            oDy = xsimd::fma(oy, wD, oDy);
            oDz = xsimd::fma(oz, wD, oDz);
            wDs = wDs + wD;
        }
        const XB block[kSums] = {eR, eG, eB, r2D, oDx, oDy, oDz, wDs};
        for (std::size_t s = 0; s < kSums; ++s) {
            float* p = sums + s * kReceivers + i;
            (XB::load_unaligned(p) + block[s]).store_unaligned(p);
        }
    }
}

using Kernel = void (*)(const Vals&, std::size_t, std::size_t, const Receivers&, std::size_t, float*);

/// Receivers [begin, end) over all VALs, tile by tile (CpuLightSkin::Impl::gather's loop).
void gatherRange(Kernel kernel, std::size_t lanes, const Vals& v, const Receivers& r, std::size_t begin,
                 std::size_t end, float* sums) {
    for (std::size_t first = 0; first < kVals; first += kTile)
        for (std::size_t i = begin; i < end; i += lanes) kernel(v, first, std::min(first + kTile, kVals), r, i, sums);
}

double cpuMs() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

struct Timing {
    double wallMs, cpuMs;
};

/// Median wall and process CPU time of `frames` runs of body (after one warm-up).
template <class Body>
Timing timeFrames(int frames, const Body& body) {
    body();
    std::vector<double> wall, cpu;
    for (int f = 0; f < frames; ++f) {
        const auto start = std::chrono::steady_clock::now();
        const double c = cpuMs();
        body();
        cpu.push_back(cpuMs() - c);
        wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    }
    std::sort(wall.begin(), wall.end());
    std::sort(cpu.begin(), cpu.end());
    return {wall[wall.size() / 2], cpu[cpu.size() / 2]};
}

} // namespace

int main(int argc, char** argv) {
    const int frames = argc > 1 ? std::max(1, std::atoi(argv[1])) : 15;
    Vals v;
    Receivers r;
    makeScene(v, r);
    const std::size_t hwyLanes = hn::Lanes(HD()), xLanes = XB::size;
    std::vector<float> sumsH(kSums * kReceivers), sumsX(kSums * kReceivers);
    const double interactions = double(kReceivers) * double(kVals);
    std::printf("lightskin_bench_cpu_libs: %zu receivers x %zu VALs, diffuse gather, %d frames (median)\n", kReceivers,
                kVals, frames);
    std::printf("Highway %s (%zu lanes), xsimd %s (%zu lanes); load average: ", hwy::TargetName(HWY_STATIC_TARGET),
                hwyLanes, xsimd::default_arch::name(), xLanes);
    if (FILE* f = std::fopen("/proc/loadavg", "r")) {
        char line[128] = {};
        if (std::fgets(line, sizeof line, f)) std::printf("%s", line);
        std::fclose(f);
    }

    // 1. SIMD library, one thread.
    const auto runH = [&] {
        std::fill(sumsH.begin(), sumsH.end(), 0.0f);
        gatherRange(hwyGather, hwyLanes, v, r, 0, kReceivers, sumsH.data());
    };
    const auto runX = [&] {
        std::fill(sumsX.begin(), sumsX.end(), 0.0f);
        gatherRange(xsimdGather, xLanes, v, r, 0, kReceivers, sumsX.data());
    };
    // interleaved, so that both see the same machine load
    Timing h{1e30, 1e30}, x{1e30, 1e30};
    for (int round = 0; round < 3; ++round) {
        const Timing th = timeFrames(frames, runH), tx = timeFrames(frames, runX);
        h = {std::min(h.wallMs, th.wallMs), std::min(h.cpuMs, th.cpuMs)};
        x = {std::min(x.wallMs, tx.wallMs), std::min(x.cpuMs, tx.cpuMs)};
    }
    // per sum, relative to its largest magnitude (offset sums cross zero: differences of large terms)
    double worst = 0.0;
    for (std::size_t s = 0; s < kSums; ++s) {
        double largest = 1e-30;
        for (std::size_t i = 0; i < kReceivers; ++i)
            largest = std::max(largest, double(std::abs(sumsH[s * kReceivers + i])));
        for (std::size_t i = 0; i < kReceivers; ++i)
            worst = std::max(worst, double(std::abs(sumsH[s * kReceivers + i] - sumsX[s * kReceivers + i])) / largest);
    }
    std::printf("\nSIMD, 1 thread          | wall ms | CPU ms | interactions per CPU-s\n");
    std::printf("Highway                 | %7.2f | %6.2f | %.3g\n", h.wallMs, h.cpuMs, interactions / (h.cpuMs * 1e-3));
    std::printf("xsimd                   | %7.2f | %6.2f | %.3g\n", x.wallMs, x.cpuMs, interactions / (x.cpuMs * 1e-3));
    std::printf("xsimd / Highway CPU time: %.3f; largest relative difference of the sums: %.2g\n", x.cpuMs / h.cpuMs,
                worst);

    // 2. Thread library, the Highway kernel, contiguous receiver ranges of whole vectors.
    std::printf("\nthreads, Highway kernel | wall ms | CPU ms | interactions per CPU-s\n");
    for (const int threads : {1, 2}) {
        const std::size_t groups = kReceivers / hwyLanes;
        const auto range = [&](std::size_t t, std::size_t n, float* sums) {
            const std::size_t begin = groups * t / n * hwyLanes, end = groups * (t + 1) / n * hwyLanes;
            if (begin < end) gatherRange(hwyGather, hwyLanes, v, r, begin, end, sums);
        };
        const auto runOmp = [&] {
            std::fill(sumsH.begin(), sumsH.end(), 0.0f);
#pragma omp parallel num_threads(threads)
            range(std::size_t(omp_get_thread_num()), std::size_t(omp_get_num_threads()), sumsH.data());
        };
        tbb::task_arena arena(threads);
        const auto runTbb = [&] {
            std::fill(sumsX.begin(), sumsX.end(), 0.0f);
            arena.execute([&] {
                tbb::parallel_for(
                    tbb::blocked_range<std::size_t>(0, std::size_t(threads), 1),
                    [&](const tbb::blocked_range<std::size_t>& b) {
                        for (std::size_t t = b.begin(); t < b.end(); ++t) range(t, std::size_t(threads), sumsX.data());
                    },
                    tbb::static_partitioner());
            });
        };
        Timing o{1e30, 1e30}, t{1e30, 1e30};
        for (int round = 0; round < 3; ++round) {
            const Timing to = timeFrames(frames, runOmp), tt = timeFrames(frames, runTbb);
            o = {std::min(o.wallMs, to.wallMs), std::min(o.cpuMs, to.cpuMs)};
            t = {std::min(t.wallMs, tt.wallMs), std::min(t.cpuMs, tt.cpuMs)};
        }
        const bool same = std::equal(sumsH.begin(), sumsH.end(), sumsX.begin());
        std::printf("OpenMP, %d thread(s)     | %7.2f | %6.2f | %.3g\n", threads, o.wallMs, o.cpuMs,
                    interactions / (o.cpuMs * 1e-3));
        std::printf("oneTBB, %d thread(s)     | %7.2f | %6.2f | %.3g   (sums %s OpenMP's)\n", threads, t.wallMs,
                    t.cpuMs, interactions / (t.cpuMs * 1e-3), same ? "bit-identical to" : "DIFFER from");
    }
    return 0;
}
