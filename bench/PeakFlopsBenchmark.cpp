// The machine's arithmetic peak, the yardstick for the GI gather's throughput (docs/BENCHMARKS.md):
//   build/bench/lightskin_bench_peak [--benchmark_repetitions=3]
//
// CPU: single-precision FMA in vector registers, 12 independent accumulator chains (more than FMA
// latency x FMA ports, so the loop is throughput-bound), on 1 and 2 threads, once per instruction set
// with FMA units that this CPU supports: AVX2 (256-bit, the width llvmpipe's LLVM back end uses) and
// AVX-512 (512-bit) where present. The kernel is compiled per instruction set by Highway and picked at
// run time, like the GI backend's kernels: nothing here is built for the build machine's CPU, and
// the peak is measured with the same code generation as the kernels compared with it. Counter
// GFLOP/s = 2 flops per FMA lane over the benchmark's time: wall time for the /real_time rows, CPU
// time of the threads otherwise (the rate per core while it runs, independent of other jobs on a
// shared machine).
//
// llvmpipe: a fragment shader (bench/shaders/fma_peak.frag) of 8 independent vec4 FMA chains per
// fragment over a 1024x1024 RGBA32F viewport (one draw), timed by wall clock from the draw call to
// glFinish (manual time; the same GFLOP/s counter). llvmpipe runs fragments on its own threads
// (LP_NUM_THREADS, default: every core), 8 fragments per 256-bit vector. The GL timestamp queries
// around the draw (gl::GpuStageTimer) are recorded too: counter query/wall. For this single large
// draw llvmpipe's queried interval covers only a small part of the work (query/wall ~0.01-0.02
// measured), so the wall clock is the measure here; the techniques' stage times are checked
// against wall time separately (`lightskin bench`, CPU column).
#include <lightskin/gl/Context.h>
#include <lightskin/gl/EmbeddedFile.h>
#include <lightskin/gl/GpuTimer.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/gl/ShaderLibrary.h>

#include <benchmark/benchmark.h>
#include <epoxy/gl.h>

#include <chrono>
#include <cstdint>
#include <ctime>
#include <memory>
#include <span>
#include <string>
#include <vector>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "PeakFlopsBenchmark.cpp"
#include <hwy/foreach_target.h> // re-includes this file once per target
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace lightskin::bench::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

/// 12 independent accumulators, `steps` FMA steps each; returns the flops (2 per FMA lane).
double FmaChains(std::uint64_t steps, float start, float* sink) {
    constexpr int kChains = 12; // FMA latency 4 x 2 ports = 8 chains in flight needed; 12 leaves margin
    const hn::ScalableTag<float> d;
    const auto a = hn::Set(d, 0.999999f), b = hn::Set(d, 1.0e-3f); // converges to b / (1 - a): never denormal
    hn::Vec<decltype(d)> acc[kChains];
    for (int c = 0; c < kChains; ++c) acc[c] = hn::Set(d, start + float(c));
    for (std::uint64_t i = 0; i < steps; ++i)
        for (int c = 0; c < kChains; ++c) acc[c] = hn::MulAdd(acc[c], a, b);
    auto sum = acc[0];
    for (int c = 1; c < kChains; ++c) sum = hn::Add(sum, acc[c]);
    *sink = hn::GetLane(sum);
    return 2.0 * kChains * double(hn::Lanes(d)) * double(steps);
}

} // namespace lightskin::bench::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace lightskin::bench {
std::span<const gl::EmbeddedFile> embeddedShaders();

namespace {

HWY_EXPORT(FmaChains);

using FmaChainsFunction = double (*)(std::uint64_t, float, float*);

/// The kernel compiled for `target` (one of hwy::SupportedAndGeneratedTargets()).
FmaChainsFunction fmaChainsFor(std::int64_t target) {
    hwy::SetSupportedTargetsForTest(target);
    hwy::GetChosenTarget().Update(hwy::SupportedTargets());
    const FmaChainsFunction function = &HWY_DYNAMIC_DISPATCH(FmaChains);
    hwy::SetSupportedTargetsForTest(0);
    return function;
}

constexpr std::uint64_t kStepsPerCall = 4096; // FMA steps per chain per benchmark iteration

void cpuFma(benchmark::State& state, FmaChainsFunction fmaChains, int bits) {
    float sink = 0.0f;
    double flops = 0.0;
    for (auto _ : state) {
        flops += fmaChains(kStepsPerCall, float(state.thread_index()), &sink);
        benchmark::DoNotOptimize(sink);
    }
    state.counters["GFLOP/s"] = benchmark::Counter(flops * 1e-9, benchmark::Counter::kIsRate);
    state.SetLabel(std::to_string(bits) + "-bit FMA, 12 chains");
}

/// One benchmark per instruction set with FMA instructions that this CPU supports, on 1 and 2 threads,
/// by wall time and by the threads' CPU time.
void registerCpuFmaBenchmarks() {
    for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
        if ((target & (HWY_AVX2 | HWY_AVX3 | HWY_AVX3_DL)) == 0) continue; // SSE4 and below have no FMA
        const FmaChainsFunction function = fmaChainsFor(target);
        const int bits = target == HWY_AVX2 ? 256 : 512;
        const std::string name = std::string("BM_CpuFma/") + hwy::TargetName(target);
        const auto run = [function, bits](benchmark::State& state) { cpuFma(state, function, bits); };
        benchmark::RegisterBenchmark(name.c_str(), run)->Threads(1)->Threads(2)->UseRealTime();
        benchmark::RegisterBenchmark(name.c_str(), run)->Threads(1)->Threads(2);
    }
}

/// The headless context and the peak program, made once (benchmarks run on the main thread).
struct GlPeak {
    std::unique_ptr<gl::Context> context;
    gl::ShaderLibrary library{bench::embeddedShaders()};
    gl::Program program;
    gl::Texture target;
    gl::Framebuffer framebuffer;
    gl::VertexArray vertexArray;
    gl::GpuStageTimer timer;
    std::vector<gl::StageTime> stages;
};

/// CPU time of the whole process (all threads, llvmpipe's rasteriser threads included), seconds.
double processCpuSeconds() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

constexpr int kSize = 1024;  // viewport side, fragments
constexpr int kGlChains = 8; // vec4 chains per fragment (fma_peak.frag's CHAINS)

GlPeak& glPeak() {
    static const std::unique_ptr<GlPeak> peak = [] {
        auto p = std::make_unique<GlPeak>();
        p->context = gl::createHeadlessContext();
        const std::vector<std::string> defines{"CHAINS " + std::to_string(kGlChains)};
        p->program = p->library.buildProgram(
            {{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "fma_peak.frag"}}, defines);
        p->target = gl::Texture::create2D(GL_RGBA32F, kSize, kSize);
        p->framebuffer = gl::Framebuffer::create();
        p->framebuffer.attach(GL_COLOR_ATTACHMENT0, p->target);
        p->framebuffer.checkComplete("fma peak target");
        p->vertexArray = gl::VertexArray::create();
        p->timer = gl::GpuStageTimer::create(1);
        return p;
    }();
    return *peak;
}

void BM_LlvmpipeFma(benchmark::State& state) {
    GlPeak& p = glPeak();
    const int iterations = int(state.range(0));
    glBindFramebuffer(GL_FRAMEBUFFER, p.framebuffer.id());
    glViewport(0, 0, kSize, kSize);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_BLEND);
    glBindVertexArray(p.vertexArray.id());
    p.program.use();
    glUniform1i(p.program.uniformLocation("uIterations"), iterations);
    glUniform1f(p.program.uniformLocation("uA"), 0.999999f);
    glUniform1f(p.program.uniformLocation("uB"), 1.0e-3f);
    glDrawArrays(GL_TRIANGLES, 0, 3); // warm-up (shader compile on first draw)
    glFinish();
    double flops = 0.0, wallSeconds = 0.0, queriedSeconds = 0.0, cpuSeconds = 0.0;
    for (auto _ : state) {
        const double cpuStart = processCpuSeconds();
        const auto start = std::chrono::steady_clock::now();
        p.timer.beginFrame();
        p.timer.begin("fma");
        glDrawArrays(GL_TRIANGLES, 0, 3);
        p.timer.end();
        glFinish();
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        cpuSeconds += processCpuSeconds() - cpuStart;
        p.timer.collect(p.stages);
        const double queried = p.stages.at(0).milliseconds / 1000.0;
        state.SetIterationTime(wall);
        wallSeconds += wall;
        queriedSeconds += queried;
        flops += 8.0 * kGlChains * double(iterations) * double(kSize) * double(kSize);
    }
    state.counters["query/wall"] = queriedSeconds / wallSeconds;
    // Flops per CPU-second of this process (llvmpipe's threads included): the shader's rate per
    // core while it runs, independent of other jobs sharing the machine.
    state.counters["GFLOP/cpu-s"] = flops * 1e-9 / cpuSeconds;
    float pixel[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    glReadPixels(kSize / 2, kSize / 2, 1, 1, GL_RGBA, GL_FLOAT, pixel);
    benchmark::DoNotOptimize(pixel);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    state.counters["GFLOP/s"] = benchmark::Counter(flops * 1e-9, benchmark::Counter::kIsRate);
    state.SetLabel(p.context->describe() + ", " + std::to_string(kSize) + "x" + std::to_string(kSize) + " fragments, " +
                   std::to_string(kGlChains) + " vec4 chains");
}
BENCHMARK(BM_LlvmpipeFma)->Arg(256)->Arg(1024)->UseManualTime()->Unit(benchmark::kMillisecond);

} // namespace
} // namespace lightskin::bench

int main(int argc, char** argv) {
    lightskin::bench::registerCpuFmaBenchmarks();
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
#endif // HWY_ONCE
