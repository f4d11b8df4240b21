// `lightskin bench-cpu`: the CPU backend (gi::CpuLightSkin) beside the GL path in one
// run, on bench-gather's scene (a sphere over a floor, 2/3 of the sparse points on the sphere, lit
// by a depth-camera-like VAL map): per setup (diffuse; + glossy; + occlusion) the stage times of
// both backends, the CPU gather's and occlusion's interactions per second and their share of the
// FMA peak (measured in the run, per CPU-second, at the same instruction set; and --peak, the
// all-core GFLOP/s of build/bench/lightskin_bench_peak, for the wall-clock rates), per
// thread count and SIMD instruction set, and the CPU image's difference from the GL image.
// A benchmark, not a test: results go to docs/BENCHMARKS.md with the command line.
//
// Flops per interaction follow docs/BENCHMARKS.md's count of lightskin_math.glsl (add, sub, mul
// = 1, FMA = 2, div, sqrt, log, exp = 1; max/min/select not counted): gather 48 / 80 / 91
// (diffuse / + glossy / + moments); occlusion (ls_occluderAmount) 57 for the diffuse target and
// 17 more for the glossy one.
#include <lightskin/bench/BenchReport.h>
#include <lightskin/bench/BenchScene.h>
#include <lightskin/bench/CpuBench.h>
#include <lightskin/bench/StopRequest.h>
#include <lightskin/core/CpuTime.h>
#include <lightskin/core/Error.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gi/common/VertexSparsePoints.h>
#include <lightskin/gi/lightskin/CpuLightSkin.h>
#include <lightskin/gi/lightskin/LightSkinIllumination.h>
#include <lightskin/gl/Context.h>
#include <lightskin/gl/DebugOutput.h>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

namespace lightskin::bench {

namespace {

using Clock = std::chrono::steady_clock;

double minimum(const std::vector<double>& v) { return v.empty() ? 0.0 : *std::min_element(v.begin(), v.end()); }

/// Stage times (minimum over frames), wall and process CPU time of render() + glFinish (minimum).
struct Timing {
    std::map<std::string, std::vector<double>> stages;
    std::vector<double> gatherCpu, occlusionCpu, stagesCpu, criticalCpu; // CpuLightSkin only
    std::vector<std::string> order;
    std::vector<double> wall, cpu;
};

template <class Technique>
Timing timeFrames(Technique& technique, const gi::ValSetView& vals, std::span<const gi::MeshInstance> instances,
                  const gi::GBufferView& gbuffer, const gi::ViewParameters& view, std::uint32_t target, int repeat) {
    Timing t;
    std::vector<gl::StageTime> stages;
    technique.render(vals, instances, gbuffer, view, target); // warm-up: first-use costs
    glFinish();
    for (int r = 0; r < repeat; ++r) {
        const double cpuStart = processCpuMs();
        const auto start = Clock::now();
        technique.render(vals, instances, gbuffer, view, target);
        glFinish();
        t.wall.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
        t.cpu.push_back(processCpuMs() - cpuStart);
        technique.lastStageTimes(stages);
        if constexpr (std::is_same_v<Technique, gi::CpuLightSkin>) {
            t.gatherCpu.push_back(technique.lastStats().gatherCpuMs);
            t.occlusionCpu.push_back(technique.lastStats().occlusionCpuMs);
            t.stagesCpu.push_back(technique.lastStats().stagesCpuMs);
            t.criticalCpu.push_back(technique.lastStats().criticalPathCpuMs);
        }
        t.order.clear();
        for (const gl::StageTime& s : stages) {
            t.stages[s.name].push_back(s.milliseconds);
            t.order.push_back(s.name);
        }
    }
    return t;
}

void printTiming(const char* label, const Timing& t) {
    std::printf("    %-22s frame %7.2f ms wall, %7.2f ms CPU |", label, minimum(t.wall), minimum(t.cpu));
    for (const std::string& name : t.order) std::printf(" %s %.2f", name.c_str(), minimum(t.stages.at(name)));
    std::printf("\n");
}

void readImage(std::uint32_t texture, std::vector<glm::vec4>& out) {
    glGetTextureImage(texture, 0, GL_RGBA, GL_FLOAT, GLsizei(out.size() * sizeof(glm::vec4)), out.data());
}

/// A JSON row of bench-cpu: wall time per frame (the minimum) as the row's time, CPU time beside it.
RunResult timedRow(const Timing& t, gi::Backend backend, const std::string& series, std::size_t vals, int sparse,
                   int channels, int width, int height) {
    RunResult r;
    r.backend = gi::toString(backend);
    r.series = series;
    r.config.axis = "vals";
    r.config.value = std::to_string(vals);
    r.config.backend = backend;
    r.config.sparse = sparse;
    r.config.channels = channels;
    r.config.width = width;
    r.config.height = height;
    r.vals = vals;
    r.gpuMs = minimum(t.wall);
    r.cpuMs = minimum(t.cpu);
    for (const std::string& name : t.order) r.stages.emplace_back(name, minimum(t.stages.at(name)));
    return r;
}

} // namespace

void runCpuBench(const CpuBenchOptions& options) {
    StopCheck stop(options.stopRequested);
    const auto started = Clock::now();
    Report report = startReport("bench-cpu", options.repeat);
    auto context = gl::createHeadlessContext();
    report.renderer = context->describe();
    std::printf("renderer: %s\nload average at start: %s\n", context->describe().c_str(), loadAverage().c_str());
    std::printf("SIMD targets: dispatched %s; available", gi::cpuSimdTarget().c_str());
    for (const std::string& t : gi::cpuSimdTargets()) std::printf(" %s", t.c_str());
    std::printf("\n");
    std::fflush(stdout);
    bench::GatherScene scene = bench::gatherScene(options.outputWidth, options.outputHeight);
    const std::vector<TriangleMesh>& meshes = scene.meshes;
    const std::vector<gi::MeshInstance>& instances = scene.instances;
    const gi::ViewParameters& view = scene.view;
    gi::SimpleGBuffer& gbuffer = scene.gbuffer;
    std::printf("output %dx%d; meshes: sphere %zu + floor %zu vertices\n", options.outputWidth, options.outputHeight,
                meshes[0].vertexCount(), meshes[1].vertexCount());
    gl::Texture target = gl::Texture::create2D(GL_RGBA32F, options.outputWidth, options.outputHeight);
    const std::size_t pixels = std::size_t(options.outputWidth) * std::size_t(options.outputHeight);
    std::vector<glm::vec4> glImage(pixels), cpuImage(pixels), flatImage;
    std::vector<std::string> targets = options.targets;
    if (targets.empty()) targets.push_back("");

    for (const std::string& mapName : options.valMaps) {
        if (stop()) break;
        const auto [mapWidth, mapHeight] = bench::parseValMapSize(mapName);
        const auto vals = bench::valMap(mapWidth, mapHeight);
        const gl::Buffer valBuffer =
            gl::Buffer::create(GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)), vals.data(), 0);
        const gi::ValSetView valSet{valBuffer.id(), std::uint32_t(vals.size())};
        // the VAL map's pixel keys (row-major, as ValGenerator's): the gather with a cut builds its quadtree
        std::vector<std::uint32_t> keys(vals.size());
        for (std::size_t i = 0; i < keys.size(); ++i) keys[i] = std::uint32_t(i);
        const gl::Buffer keyBuffer =
            gl::Buffer::create(GLsizeiptr(keys.size() * sizeof(std::uint32_t)), keys.data(), 0);
        const gi::ValSetView keyedSet{valBuffer.id(), std::uint32_t(vals.size()), 0,
                                      keyBuffer.id(), std::uint32_t(vals.size()), std::uint32_t(mapWidth)};
        for (int sparse : options.sparse) {
            if (stop()) break;
            const auto sparseSphere = std::size_t(sparse) * 2 / 3;
            const gi::SparsePointProvider provider = [&](const gi::MeshInstance& instance) {
                return gi::sparsePointsFromVertices(
                    *instance.mesh, instance.meshId == 0 ? sparseSphere : std::size_t(sparse) - sparseSphere);
            };
            std::printf("\nVAL map %s (%zu VALs), %d sparse points\n", mapName.c_str(), vals.size(), sparse);
            struct SetupSpec {
                const char* name;
                bool glossy, occlusion;
                double gatherFlops, occlusionFlops;
            };
            for (const SetupSpec setup :
                 {SetupSpec{"diffuse", false, false, 48.0, 0.0}, SetupSpec{"+glossy", true, false, 80.0, 0.0},
                  SetupSpec{"+occlusion", true, true, 91.0, 74.0}}) {
                if (stop()) break;
                std::printf("  %s\n", setup.name);
                flatImage.clear(); // the cut's error is against this setup's flat gather only
                const int channels = setup.occlusion ? 3 : setup.glossy ? 2 : 1;
                gi::LightSkinSettings settings;
                settings.glossy = setup.glossy;
                settings.occlusion = setup.occlusion;
                settings.valCapacity = std::uint32_t(vals.size());
                if (options.gl) {
                    auto gl = gi::LightSkinIllumination::create(settings, provider);
                    gl->prepare(instances);
                    const Timing t =
                        timeFrames(*gl, valSet, instances, gbuffer.view(), view, target.id(), options.repeat);
                    printTiming("GL (llvmpipe)", t);
                    report.runs.push_back(timedRow(t, gi::Backend::Gl, setup.name, vals.size(), sparse, channels,
                                                   options.outputWidth, options.outputHeight));
                    const double gatherMs = minimum(t.stages.at("gather"));
                    std::printf("      GL gather %.3g interactions/s (timer query)\n",
                                double(sparse) * double(vals.size()) / (gatherMs * 1e-3));
                    readImage(target.id(), glImage);
                }
                for (const std::string& simd : targets) {
                    if (stop()) break;
                    gi::setCpuSimdTarget(simd);
                    for (int threads : options.threads)
                        for (const float tree : options.treeThresholds) {
                            if (stop()) break;
                            gi::CpuLightSkinSettings cpuSettings;
                            cpuSettings.lightSkin = settings;
                            cpuSettings.lightSkin.valTreeThreshold = tree;
                            cpuSettings.threads = threads;
                            // the FMA peak per CPU-second now, at this instruction set: the yardstick of
                            // the rates below under the same load (other jobs share the cores)
                            const double peakNow = gi::cpuFmaPeakGflops(100.0);
                            auto cpu = gi::CpuLightSkin::create(cpuSettings, provider);
                            cpu->prepare(instances);
                            const Timing t = timeFrames(*cpu, tree > 0.0f ? keyedSet : valSet, instances,
                                                        gbuffer.view(), view, target.id(), options.repeat);
                            const std::string treeLabel = tree > 0.0f ? " tree " + std::to_string(tree) : "";
                            const std::string label =
                                "CPU " + gi::cpuSimdTarget() + " " + std::to_string(threads) + " thr" + treeLabel;
                            printTiming(label.c_str(), t);
                            report.runs.push_back(timedRow(t, gi::Backend::Cpu,
                                                           std::string(setup.name) + ", " + std::to_string(threads) +
                                                               " threads, " + gi::cpuSimdTarget() + treeLabel,
                                                           vals.size(), sparse, channels, options.outputWidth,
                                                           options.outputHeight));
                            const gi::CpuLightSkinStats& stats = cpu->lastStats();
                            // rates per CPU-second (robust to other processes' load) and by wall clock
                            const double interactions = double(stats.points) * double(stats.vals);
                            // the gather region's CPU time less its occlusion part, each the least over the
                            // frames (the occlusion part is timed by a steady clock: CpuLightSkinStats)
                            std::vector<double> regionCpu(t.gatherCpu.size());
                            for (std::size_t f = 0; f < regionCpu.size(); ++f)
                                regionCpu[f] = t.gatherCpu[f] + t.occlusionCpu[f];
                            const double gatherCpu = minimum(regionCpu) - minimum(t.occlusionCpu);
                            const double perCpuSecond = interactions / (gatherCpu * 1e-3);
                            const double perSecond = interactions / (minimum(t.stages.at("gather")) * 1e-3);
                            const double corePeak = peakNow;
                            std::printf("      gather %.3g interactions per CPU-s (%.1f GFLOP per CPU-s", perCpuSecond,
                                        perCpuSecond * setup.gatherFlops * 1e-9);
                            if (corePeak > 0.0)
                                std::printf(", %.1f %% of the in-run FMA peak %.0f GFLOP per CPU-s",
                                            100.0 * perCpuSecond * setup.gatherFlops * 1e-9 / corePeak, corePeak);
                            std::printf("), %.3g per wall-s (%.1f GFLOP/s", perSecond,
                                        perSecond * setup.gatherFlops * 1e-9);
                            if (options.peakGflops > 0.0)
                                std::printf(", %.1f %% of the %.0f peak",
                                            100.0 * perSecond * setup.gatherFlops * 1e-9 / options.peakGflops,
                                            options.peakGflops);
                            // interactions above count every VAL x point pair, also those of the skipped blocks
                            std::printf(
                                "); %.1f %% of its (16 VALs, point) pairs in blocks skipped as hidden (exact)\n",
                                100.0 * stats.gatherBlocksSkipped);
                            if (setup.occlusion) {
                                const double pairs = double(stats.points) * double(stats.points);
                                const double occCpu = pairs / (minimum(t.occlusionCpu) * 1e-3);
                                std::printf("      occlusion %.3g interactions per CPU-s (%.1f GFLOP per CPU-s", occCpu,
                                            occCpu * setup.occlusionFlops * 1e-9);
                                if (corePeak > 0.0)
                                    std::printf(", %.1f %% of the in-run peak",
                                                100.0 * occCpu * setup.occlusionFlops * 1e-9 / corePeak);
                                std::printf(")\n");
                            }
                            const double gi = minimum(t.stages.at("upload")) + minimum(t.stages.at("gather")) +
                                              minimum(t.stages.at("normalisation")) +
                                              minimum(t.stages.at("occlusion")) + minimum(t.stages.at("interpolation"));
                            // critical path: serial CPU time + the busiest thread's of each parallel region
                            // (thread CPU clocks): the wall time on idle cores, whatever else runs now
                            std::printf("      GI stages 0-4: %.2f ms wall (sum of stage minima), %.2f ms CPU; CPU / "
                                        "threads: %.2f ms; critical path (wall on idle cores): %.2f ms\n",
                                        gi, minimum(t.stagesCpu), minimum(t.stagesCpu) / double(threads),
                                        minimum(t.criticalCpu));
                            readImage(target.id(), cpuImage);
                            if (tree <= 0.0f)
                                flatImage = cpuImage;
                            else if (flatImage.size() == cpuImage.size()) {
                                double squaredError = 0.0, squaredFlat = 0.0;
                                for (std::size_t i = 0; i < pixels; ++i)
                                    for (int c = 0; c < 3; ++c) {
                                        const double d = double(cpuImage[i][c]) - double(flatImage[i][c]);
                                        squaredError += d * d;
                                        squaredFlat += double(flatImage[i][c]) * double(flatImage[i][c]);
                                    }
                                std::printf("      cut %.3g lights per point; relMSE vs the flat gather's image %.3e\n",
                                            stats.valTreeCutPerPoint,
                                            squaredFlat > 0.0 ? squaredError / squaredFlat : 0.0);
                            }
                            if (options.gl) {
                                double sumAbs = 0.0, sumGl = 0.0, worst = 0.0, largest = 0.0;
                                for (const glm::vec4& p : glImage)
                                    largest = std::max({largest, double(p.x), double(p.y), double(p.z)});
                                for (std::size_t i = 0; i < pixels; ++i)
                                    for (int c = 0; c < 3; ++c) {
                                        const double d = std::abs(double(cpuImage[i][c]) - double(glImage[i][c]));
                                        sumAbs += d;
                                        sumGl += double(glImage[i][c]);
                                        worst = std::max(worst, d / std::max(double(glImage[i][c]), 1e-2 * largest));
                                    }
                                std::printf(
                                    "      image vs GL: mean abs %.2e of the mean, worst %.2e relative (floor 1e-2 "
                                    "of max)\n",
                                    sumGl > 0.0 ? sumAbs / sumGl : 0.0, worst);
                            }
                            std::fflush(stdout);
                        }
                }
                gi::setCpuSimdTarget("");
            }
        }
    }
    report.loadEnd = loadAverage();
    std::printf("\nload average at end: %s\n", report.loadEnd.c_str());
    gl::DebugOutput::throwIfErrors("bench-cpu");
    report.seconds = std::chrono::duration<double>(Clock::now() - started).count();
    report.interrupted = stop();
    if (!options.out.empty()) writeJsonAndPlots(report, options.out);
    if (report.interrupted) printInterrupted("bench-cpu");
}

} // namespace lightskin::bench
