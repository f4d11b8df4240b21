// The machine's arithmetic peak, the yardstick for the GI gather's throughput (docs/BENCHMARKS.md):
//   build/bench/lightskin_bench_peak [--benchmark_repetitions=3]
//
// CPU: single-precision FMA in vector registers, kChains independent accumulator chains (more than
// FMA latency x FMA ports, so the loop is throughput-bound), on 1 and 2 threads. Two widths: 256-bit
// (AVX2 + FMA3: the width llvmpipe's LLVM back end uses, "256 bits" in its renderer string) and 512-bit
// (AVX-512F, when the compiler targets it). Counter GFLOP/s = 2 flops per FMA lane over the
// benchmark's time: wall time for the /real_time rows, CPU time of the threads otherwise (the rate per
// core while it runs, independent of other jobs on a shared machine).
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
#include <immintrin.h>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace lightskin::bench {
std::span<const gl::EmbeddedFile> embeddedShaders();
} // namespace lightskin::bench

namespace {

using namespace lightskin;

constexpr int kChains = 12;         // independent accumulators (FMA latency 4 x 2 ports = 8 needed)
constexpr int kStepsPerCall = 4096; // FMA steps per chain per benchmark iteration

template <typename V, V (*Set1)(float), V (*Fma)(V, V, V), int Lanes>
void cpuFma(benchmark::State& state) {
    const V a = Set1(0.999999f), b = Set1(1.0e-3f); // converges to b / (1 - a): finite, never denormal
    V acc[kChains];
    for (int c = 0; c < kChains; ++c) acc[c] = Set1(float(c + state.thread_index()));
    for (auto _ : state) {
        for (int i = 0; i < kStepsPerCall; ++i) {
            for (int c = 0; c < kChains; ++c) acc[c] = Fma(acc[c], a, b);
        }
        for (int c = 0; c < kChains; ++c) benchmark::DoNotOptimize(acc[c]);
    }
    const double flops = 2.0 * Lanes * kChains * double(kStepsPerCall) * double(state.iterations());
    state.counters["GFLOP/s"] = benchmark::Counter(flops * 1e-9, benchmark::Counter::kIsRate);
    state.SetLabel(std::to_string(Lanes * 32) + "-bit FMA, " + std::to_string(kChains) + " chains");
}

#if defined(__AVX2__) && defined(__FMA__)
__m256 set1x8(float v) { return _mm256_set1_ps(v); }
__m256 fmax8(__m256 a, __m256 b, __m256 c) { return _mm256_fmadd_ps(a, b, c); }
void BM_CpuFma256(benchmark::State& state) { cpuFma<__m256, set1x8, fmax8, 8>(state); }
BENCHMARK(BM_CpuFma256)->Threads(1)->Threads(2)->UseRealTime();
BENCHMARK(BM_CpuFma256)->Threads(1)->Threads(2);
#endif

#if defined(__AVX512F__)
__m512 set1x16(float v) { return _mm512_set1_ps(v); }
__m512 fmax16(__m512 a, __m512 b, __m512 c) { return _mm512_fmadd_ps(a, b, c); }
void BM_CpuFma512(benchmark::State& state) { cpuFma<__m512, set1x16, fmax16, 16>(state); }
BENCHMARK(BM_CpuFma512)->Threads(1)->Threads(2)->UseRealTime();
BENCHMARK(BM_CpuFma512)->Threads(1)->Threads(2);
#endif

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

BENCHMARK_MAIN();
