// `lightskin bench-gather`: timings of the LightSkin stages (GL timer queries: upload, gather,
// normalisation, occlusion, interpolation, shading) for the paper's three setups, the speed-up
// over the brute force at equal inputs with the error at that point, and the gather throughput
// in VAL-receiver interactions per second. A benchmark, not a test: results go to
// docs/BENCHMARKS.md with the command line that produced them.
//
// Scene: a sphere over a floor (two meshes, 2/3 of the sparse points on the sphere), lit by a
// VAL "map" (a width x height grid of disc VALs on a wall and the ceiling, like a depth camera's
// VAL map), seen by a camera at the output resolution.
#include <lightskin/bench/BenchReport.h>
#include <lightskin/bench/BenchScene.h>
#include <lightskin/bench/GatherBench.h>
#include <lightskin/core/Error.h>
#include <lightskin/gi/BruteForceIllumination.h>
#include <lightskin/gi/LightSkinIllumination.h>
#include <lightskin/gi/SimpleGBuffer.h>
#include <lightskin/gi/VertexSparsePoints.h>
#include <lightskin/gl/Context.h>
#include <lightskin/gl/DebugOutput.h>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <string>
#include <vector>

namespace lightskin::bench {

namespace {

double minimum(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

} // namespace

void runGatherBench(const GatherBenchOptions& options) {
    const auto started = std::chrono::steady_clock::now();
    Report report = startReport("bench-gather", options.repeat);
    auto context = gl::createHeadlessContext();
    report.renderer = context->describe();
    std::printf("renderer: %s\n", context->describe().c_str());
    bench::GatherScene scene = bench::gatherScene(options.outputWidth, options.outputHeight);
    const std::vector<TriangleMesh>& meshes = scene.meshes;
    const std::vector<gi::MeshInstance>& instances = scene.instances;
    const gi::ViewParameters& view = scene.view;
    gi::SimpleGBuffer& gbuffer = scene.gbuffer;
    std::vector<glm::vec4> positions(std::size_t(options.outputWidth) * std::size_t(options.outputHeight));
    glGetTextureImage(gbuffer.position().id(), 0, GL_RGBA, GL_FLOAT, GLsizei(positions.size() * sizeof(glm::vec4)),
                      positions.data());
    const auto covered =
        std::size_t(std::count_if(positions.begin(), positions.end(), [](const glm::vec4& p) { return p.w != 0.0f; }));
    std::printf("output %dx%d, %zu covered pixels; meshes: sphere %zu + floor %zu vertices\n", options.outputWidth,
                options.outputHeight, covered, meshes[0].vertexCount(), meshes[1].vertexCount());
    gl::Texture target = gl::Texture::create2D(GL_RGBA32F, options.outputWidth, options.outputHeight);
    std::vector<glm::vec4> image(positions.size()), reference(positions.size());
    auto readImage = [&](std::vector<glm::vec4>& out) {
        glGetTextureImage(target.id(), 0, GL_RGBA, GL_FLOAT, GLsizei(out.size() * sizeof(glm::vec4)), out.data());
    };

    for (const std::string& mapName : options.valMaps) {
        const auto [mapWidth, mapHeight] = bench::parseValMapSize(mapName);
        const auto vals = bench::valMap(mapWidth, mapHeight);
        const gl::Buffer valBuffer =
            gl::Buffer::create(GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)), vals.data(), 0);
        // the VAL map's pixel keys (row-major, as ValGenerator's): the tree gather builds its quadtree
        std::vector<std::uint32_t> keys(vals.size());
        for (std::size_t i = 0; i < keys.size(); ++i) keys[i] = std::uint32_t(i);
        const gl::Buffer keyBuffer =
            gl::Buffer::create(GLsizeiptr(keys.size() * sizeof(std::uint32_t)), keys.data(), 0);
        const gi::ValSetView valSet{valBuffer.id(), std::uint32_t(vals.size())};
        const gi::ValSetView keyedSet{valBuffer.id(), std::uint32_t(vals.size()), 0,
                                      keyBuffer.id(), std::uint32_t(vals.size()), std::uint32_t(mapWidth)};

        // The rows of the JSON: what the table below prints (one per setup; the brute force's own row).
        RunResult row;
        row.config.axis = "vals";
        row.config.value = mapName;
        row.config.width = options.outputWidth;
        row.config.height = options.outputHeight;
        row.vals = vals.size();
        row.covered = covered;
        row.triangles = meshes[0].triangleCount() + meshes[1].triangleCount();
        double bruteMs = 0.0;
        if (options.brute) {
            gi::BruteForceSettings bruteSettings;
            bruteSettings.glossy = false;
            bruteSettings.nearFieldArea = options.nearField;
            auto brute = gi::BruteForceIllumination::create(bruteSettings);
            // Wall time of render() + glFinish: llvmpipe's timestamp queries under-report the brute force's
            // single full-screen stage (docs/BENCHMARKS.md, "Table 1 setups").
            std::vector<double> times;
            glFinish();
            for (int r = 0; r < std::max(1, options.repeat / 2); ++r) {
                const auto start = std::chrono::steady_clock::now();
                brute->render(valSet, instances, gbuffer.view(), view, target.id());
                glFinish();
                times.push_back(
                    std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
            }
            bruteMs = minimum(times);
            readImage(reference);
            RunResult bruteRow = row;
            bruteRow.method = "brute force";
            bruteRow.isBrute = true;
            bruteRow.config.channels = 1;
            bruteRow.config.sparse = 0;
            bruteRow.bruteMs = bruteMs;
            bruteRow.gpuMs = bruteMs;
            bruteRow.cpuMs = bruteMs;
            report.runs.push_back(bruteRow);
            std::printf("\nVAL map %s (%zu VALs): brute force (diffuse) %.1f ms, %.3g interactions/s\n",
                        mapName.c_str(), vals.size(), bruteMs,
                        double(covered) * double(vals.size()) / (bruteMs * 1e-3));
        } else {
            std::printf("\nVAL map %s (%zu VALs)\n", mapName.c_str(), vals.size());
        }

        for (int sparse : options.sparse)
            for (int kCache : options.kCache) {
                const auto sparseSphere = std::size_t(sparse) * 2 / 3;
                const gi::SparsePointProvider provider = [&](const gi::MeshInstance& instance) {
                    return gi::sparsePointsFromVertices(
                        *instance.mesh, instance.meshId == 0 ? sparseSphere : std::size_t(sparse) - sparseSphere);
                };
                struct SetupSpec {
                    const char* name;
                    bool glossy, occlusion;
                };
                for (const float threshold : options.treeThresholds)
                    for (const bool bvh : {false, true})
                        for (const SetupSpec setup :
                             {SetupSpec{"diffuse", false, false}, SetupSpec{"+glossy", true, false},
                              SetupSpec{"+occlusion", true, true}}) {
                            if (options.diffuseOnly && setup.glossy) continue;
                            if (bvh && (threshold <= 0.0f || !options.treeBvh)) continue;
                            const gi::ValSetView& lightSet = threshold > 0.0f && !bvh ? keyedSet : valSet;
                            gi::LightSkinSettings settings;
                            settings.valTreeThreshold = threshold;
                            settings.kCache = kCache;
                            settings.glossy = setup.glossy;
                            settings.occlusion = setup.occlusion;
                            settings.valCapacity = std::uint32_t(vals.size());
                            settings.computeGather = options.compute;
                            settings.nearFieldArea = options.nearField;
                            auto technique = gi::LightSkinIllumination::create(settings, provider);
                            technique->prepare(instances);
                            std::map<std::string, std::vector<double>> stageTimes;
                            std::vector<gl::StageTime> stages;
                            std::vector<double> totals, walls;
                            for (int r = 0; r < options.repeat; ++r) {
                                glFinish();
                                const auto start = std::chrono::steady_clock::now();
                                technique->render(lightSet, instances, gbuffer.view(), view, target.id());
                                glFinish();
                                // wall clock too: the tree gather's dispatch loop and CPU build are not one timed draw
                                walls.push_back(
                                    std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                                        .count());
                                technique->lastStageTimes(stages);
                                double total = 0.0;
                                for (const auto& s : stages) {
                                    stageTimes[s.name].push_back(s.milliseconds);
                                    total += s.milliseconds;
                                }
                                totals.push_back(total);
                            }
                            const double gatherMs = minimum(stageTimes["gather"]);
                            // the tree gather's GPU timer misses its CPU build: take the larger of the two totals
                            const double totalMs = std::max(minimum(totals), minimum(walls));
                            RunResult run = row;
                            run.series =
                                "sparse " + std::to_string(sparse) + ", K_cache " + std::to_string(kCache) + ", " +
                                setup.name + (options.compute ? ", compute" : "") +
                                (threshold > 0.0f ? (bvh ? ", tree (BVH) " : ", tree ") + std::to_string(threshold)
                                                  : std::string());
                            run.config.sparse = sparse;
                            run.config.kCache = kCache;
                            run.config.valTree = threshold;
                            run.config.channels = setup.occlusion ? 3 : setup.glossy ? 2 : 1;
                            run.gpuMs = totalMs;
                            for (const auto& s : stages) run.stages.emplace_back(s.name, minimum(stageTimes[s.name]));
                            if (options.brute && !setup.glossy) run.bruteMs = bruteMs; // on the same (diffuse) inputs
                            report.runs.push_back(std::move(run));
                            std::printf("  sparse %5d K_cache %4d tree %-6g %-8s %-10s total %8.2f ms (wall %8.2f) |",
                                        sparse, kCache, double(threshold),
                                        threshold <= 0.0f                         ? "flat"
                                        : technique->lastChoice().valTreeQuadtree ? "quadtree"
                                                                                  : "bvh",
                                        setup.name, totalMs, minimum(walls));
                            if (threshold > 0.0f)
                                std::printf(
                                    " cut %.0f lights/point, %.0f nodes visited/point, read-back + build + upload "
                                    "%.1f ms |",
                                    double(technique->lastChoice().valTreeCutPerPoint),
                                    double(technique->lastChoice().valTreeVisitedPerPoint),
                                    double(technique->lastChoice().valTreeBuildMs));
                            for (const auto& s : stages)
                                std::printf(" %s %.2f", s.name.c_str(), minimum(stageTimes[s.name]));
                            std::printf(" | gather %.3g interactions/s",
                                        double(sparse) * double(vals.size()) / (gatherMs * 1e-3));
                            if (options.brute && !setup.glossy) {
                                readImage(image);
                                double sumAbs = 0.0, sumRef = 0.0, sum = 0.0, sq = 0.0, sqRef = 0.0;
                                for (std::size_t i = 0; i < image.size(); ++i)
                                    for (int c = 0; c < 3; ++c) {
                                        const double d = double(image[i][c] - reference[i][c]);
                                        sumAbs += std::abs(d);
                                        sq += d * d;
                                        sqRef += double(reference[i][c]) * double(reference[i][c]);
                                        sumRef += double(reference[i][c]);
                                        sum += double(image[i][c]);
                                    }
                                std::printf(
                                    " | speed-up over brute force %.1fx, mean abs error %.2f%% of the mean, total "
                                    "%+.2f%%, relMSE %.3e",
                                    bruteMs / totalMs, 100.0 * sumAbs / sumRef, 100.0 * (sum / sumRef - 1.0),
                                    sqRef > 0.0 ? sq / sqRef : 0.0);
                            }
                            std::printf("\n");
                            std::fflush(stdout);
                        }
            }
    }
    gl::DebugOutput::throwIfErrors("bench-gather");
    report.loadEnd = loadAverage();
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    if (!options.out.empty()) writeJsonAndPlots(report, options.out);
}

} // namespace lightskin::bench
