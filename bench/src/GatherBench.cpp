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
#include <lightskin/bench/StopRequest.h>
#include <lightskin/core/Error.h>
#include <lightskin/gi/bruteforce/BruteForceIllumination.h>
#include <lightskin/gi/lightskin/GpuValQuadtree.h>
#include <lightskin/gi/lightskin/LightSkinIllumination.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gi/common/VertexSparsePoints.h>
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
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace lightskin::bench {

namespace {

double minimum(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

/// The diffuse brute force's row beside a LightSkin row of the same VAL map (its time in every time column).
RunResult bruteForceRow(const RunResult& row, double bruteMs, std::string series) {
    RunResult brute = row;
    brute.method = "brute force";
    brute.series = std::move(series);
    brute.isBrute = true;
    brute.config.channels = 1;
    brute.config.sparse = 0;
    brute.bruteMs = bruteMs;
    brute.gpuMs = bruteMs;
    brute.cpuMs = bruteMs;
    return brute;
}

double millisecondsSince(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

// --brute-subset: N covered pixels drawn without replacement (fixed seed), their G-buffer texels packed
// into a kSubsetWidth-wide G-buffer of their own, so that the brute force shades only them (masking the
// full-size G-buffer would still run every pixel once per VAL chunk). `empty` is the same size with no
// pixel covered: the per-chunk cost that does not scale with the pixels.
constexpr int kSubsetWidth = 64;
struct BruteSubset {
    std::vector<std::size_t> pixels; // indices into the output image
    gl::Texture position, normal, albedo, specular, emptyPosition, target;
    int width = kSubsetWidth, height = 0;
    gi::GBufferView view(bool empty) const {
        gi::GBufferView v;
        v.worldPosition = empty ? emptyPosition.id() : position.id();
        v.worldNormal = normal.id();
        v.diffuseAlbedo = albedo.id();
        v.specular = specular.id();
        v.width = width;
        v.height = height;
        return v;
    }
};

BruteSubset makeBruteSubset(const gi::SimpleGBuffer& gbuffer, const std::vector<glm::vec4>& positions, int count) {
    BruteSubset b;
    std::vector<std::size_t> covered;
    for (std::size_t i = 0; i < positions.size(); ++i)
        if (positions[i].w != 0.0f) covered.push_back(i);
    std::mt19937_64 rng(17);
    std::shuffle(covered.begin(), covered.end(), rng);
    covered.resize(std::min(covered.size(), std::size_t(count)));
    b.pixels = covered;
    b.height = int((b.pixels.size() + kSubsetWidth - 1) / kSubsetWidth);
    const gi::GBufferView full = gbuffer.view();
    const auto pack = [&](std::uint32_t texture, bool empty) {
        std::vector<glm::vec4> all(positions.size()),
            packed(std::size_t(b.width) * std::size_t(b.height), glm::vec4(0));
        glGetTextureImage(texture, 0, GL_RGBA, GL_FLOAT, GLsizei(all.size() * sizeof(glm::vec4)), all.data());
        if (!empty)
            for (std::size_t k = 0; k < b.pixels.size(); ++k) packed[k] = all[b.pixels[k]];
        gl::Texture t = gl::Texture::create2D(GL_RGBA32F, b.width, b.height);
        glTextureSubImage2D(t.id(), 0, 0, 0, b.width, b.height, GL_RGBA, GL_FLOAT, packed.data());
        return t;
    };
    b.position = pack(full.worldPosition, false);
    b.emptyPosition = pack(full.worldPosition, true);
    b.normal = pack(full.worldNormal, false);
    b.albedo = pack(full.diffuseAlbedo, false);
    b.specular = pack(full.specular, false);
    b.target = gl::Texture::create2D(GL_RGBA32F, b.width, b.height);
    return b;
}

// relMSE = sum |d|^2 / sum |ref|^2 over the subset, and its standard error from the sampling of pixels
// (delta method for a ratio of means: var(R) / R^2 ~ (var a / a^2 + var b / b^2 - 2 cov(a, b) / (a b)) / N).
struct SubsetError {
    double relMse = 0.0, standardError = 0.0;
};
SubsetError subsetError(const BruteSubset& b, const std::vector<glm::vec4>& image,
                        const std::vector<glm::vec4>& reference) {
    const auto n = double(b.pixels.size());
    double sa = 0.0, sb = 0.0, saa = 0.0, sbb = 0.0, sab = 0.0;
    for (std::size_t k = 0; k < b.pixels.size(); ++k) {
        double a = 0.0, r = 0.0;
        for (int c = 0; c < 3; ++c) {
            const double d = double(image[b.pixels[k]][c]) - double(reference[k][c]);
            a += d * d;
            r += double(reference[k][c]) * double(reference[k][c]);
        }
        sa += a;
        sb += r;
        saa += a * a;
        sbb += r * r;
        sab += a * r;
    }
    SubsetError e;
    if (sb <= 0.0 || n < 2.0) return e;
    const double ma = sa / n, mb = sb / n;
    e.relMse = ma / mb;
    const double va = saa / n - ma * ma, vb = sbb / n - mb * mb, cab = sab / n - ma * mb;
    const double relVar = (ma > 0.0 ? va / (ma * ma) - 2.0 * cab / (ma * mb) : 0.0) + vb / (mb * mb);
    e.standardError = e.relMse * std::sqrt(std::max(relVar, 0.0) / n);
    return e;
}

} // namespace

void runGatherBench(const GatherBenchOptions& options) {
    StopCheck stop(options.stopRequested);
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
    std::fflush(stdout);
    gl::Texture target = gl::Texture::create2D(GL_RGBA32F, options.outputWidth, options.outputHeight);
    std::vector<glm::vec4> image(positions.size()), reference(positions.size());
    auto readImage = [&](std::vector<glm::vec4>& out) {
        glGetTextureImage(target.id(), 0, GL_RGBA, GL_FLOAT, GLsizei(out.size() * sizeof(glm::vec4)), out.data());
    };

    BruteSubset subset;                            // --brute-subset
    std::optional<gi::GpuValQuadtree> gpuQuadtree; // created on first use
    gi::ValTree cpuQuadtree;
    std::vector<gi::VirtualAreaLight> valsBack;
    std::vector<std::uint32_t> keysBack;
    gl::Buffer nodeUpload;
    for (const std::string& mapName : options.valMaps) {
        if (stop()) break;
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
        std::vector<glm::vec4> subsetReference, flatOnSubset;
        if (options.brute && options.bruteSubset > 0) {
            if (subset.pixels.empty()) subset = makeBruteSubset(gbuffer, positions, options.bruteSubset);
            gi::BruteForceSettings bruteSettings;
            bruteSettings.glossy = false;
            auto brute = gi::BruteForceIllumination::create(bruteSettings);
            // Wall clock of render() + glFinish, the subset then the same draws with no pixel covered;
            // their difference scaled to every covered pixel leaves out the full brute force's per-chunk
            // cost over the uncovered pixels: a lower bound of its time, so the speed-up is not inflated.
            std::vector<double> withPixels, without;
            for (int r = 0; r < std::max(1, options.repeat / 2); ++r)
                for (const bool empty : {true, false}) { // the subset last: its image is the reference
                    glFinish();
                    const auto start = std::chrono::steady_clock::now();
                    brute->render(valSet, instances, subset.view(empty), view, subset.target.id());
                    glFinish();
                    (empty ? without : withPixels).push_back(millisecondsSince(start));
                }
            subsetReference.resize(std::size_t(subset.width) * std::size_t(subset.height));
            glGetTextureImage(subset.target.id(), 0, GL_RGBA, GL_FLOAT,
                              GLsizei(subsetReference.size() * sizeof(glm::vec4)), subsetReference.data());
            const double perPixel = (minimum(withPixels) - minimum(without)) / double(subset.pixels.size());
            bruteMs = perPixel * double(covered);
            report.runs.push_back(bruteForceRow(
                row, bruteMs, "estimate from " + std::to_string(subset.pixels.size()) + " random covered pixels"));
            std::printf("\nVAL map %s (%zu VALs): brute force (diffuse) on %zu of %zu covered pixels %.1f ms, no pixel "
                        "%.1f ms -> all covered pixels %.0f ms (%.3g interactions/s)\n",
                        mapName.c_str(), vals.size(), subset.pixels.size(), covered, minimum(withPixels),
                        minimum(without), bruteMs, double(covered) * double(vals.size()) / (bruteMs * 1e-3));
        } else if (options.brute) {
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
            report.runs.push_back(bruteForceRow(row, bruteMs, ""));
            std::printf("\nVAL map %s (%zu VALs): brute force (diffuse) %.1f ms, %.3g interactions/s\n",
                        mapName.c_str(), vals.size(), bruteMs,
                        double(covered) * double(vals.size()) / (bruteMs * 1e-3));
        } else {
            std::printf("\nVAL map %s (%zu VALs)\n", mapName.c_str(), vals.size());
        }

        if (std::any_of(options.treeThresholds.begin(), options.treeThresholds.end(),
                        [](float t) { return t > 0.0f; })) {
            // The quadtree of the map's VALs built both ways, alternately, wall clock: on the GPU (as the
            // tree gather does; the build ends with a 16-byte read-back) and on the CPU as the gather did
            // before (VAL + key read-back, buildValQuadtreeInto, node upload).
            if (!gpuQuadtree) gpuQuadtree = gi::GpuValQuadtree::create();
            nodeUpload = gl::Buffer::create(GLsizeiptr(2 * vals.size()) * GLsizeiptr(sizeof(gi::ValCluster)));
            std::vector<double> gpu, cpu;
            for (int r = 0; r < std::max(2, options.repeat); ++r) {
                glFinish();
                auto start = std::chrono::steady_clock::now();
                gpuQuadtree->build(keyedSet);
                gpu.push_back(millisecondsSince(start));
                glFinish();
                start = std::chrono::steady_clock::now();
                valsBack.resize(vals.size());
                keysBack.resize(vals.size());
                glGetNamedBufferSubData(valBuffer.id(), 0, GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)),
                                        valsBack.data());
                glGetNamedBufferSubData(keyBuffer.id(), 0, GLsizeiptr(vals.size() * 4), keysBack.data());
                gi::buildValQuadtreeInto(std::span<const gi::VirtualAreaLight>(valsBack),
                                         std::span<const std::uint32_t>(keysBack), std::uint32_t(mapWidth),
                                         std::uint32_t(mapHeight), cpuQuadtree);
                nodeUpload.upload(0, GLsizeiptr(cpuQuadtree.nodes.size() * sizeof(gi::ValCluster)),
                                  cpuQuadtree.nodes.data());
                glFinish();
                cpu.push_back(millisecondsSince(start));
            }
            std::printf("  quadtree build (minimum of %zu): GPU %.2f ms, CPU with read-back and upload %.2f ms "
                        "(CPU / GPU %.1fx)\n",
                        gpu.size(), minimum(gpu), minimum(cpu), minimum(cpu) / minimum(gpu));
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
                            // A stop stays asked: the loops around this one pass over their remaining values.
                            if (stop()) break;
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
                                std::printf(" cut %.0f lights/point, %.0f nodes visited/point, tree build %.1f ms |",
                                            double(technique->lastChoice().valTreeCutPerPoint),
                                            double(technique->lastChoice().valTreeVisitedPerPoint),
                                            double(technique->lastChoice().valTreeBuildMs));
                            for (const auto& s : stages)
                                std::printf(" %s %.2f", s.name.c_str(), minimum(stageTimes[s.name]));
                            std::printf(" | gather %.3g interactions/s",
                                        double(sparse) * double(vals.size()) / (gatherMs * 1e-3));
                            if (options.brute && !setup.glossy && options.bruteSubset > 0) {
                                readImage(image);
                                const SubsetError e = subsetError(subset, image, subsetReference);
                                std::printf(" | speed-up over brute force %.1fx (estimate), relMSE %.3e +- %.1e on %zu "
                                            "pixels",
                                            bruteMs / totalMs, e.relMse, e.standardError, subset.pixels.size());
                                // the flat gather's image on the same pixels: what the cut adds, paired (the
                                // sampling error of the two relMSEs above is mostly shared)
                                if (threshold <= 0.0f) {
                                    flatOnSubset.resize(subset.pixels.size());
                                    for (std::size_t k = 0; k < subset.pixels.size(); ++k)
                                        flatOnSubset[k] = image[subset.pixels[k]];
                                } else if (flatOnSubset.size() == subset.pixels.size()) {
                                    const SubsetError f = subsetError(subset, image, flatOnSubset);
                                    std::printf(", against the flat gather's image %.3e +- %.1e", f.relMse,
                                                f.standardError);
                                }
                            } else if (options.brute && !setup.glossy) {
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
    report.interrupted = stop();
    if (!options.out.empty()) writeJsonAndPlots(report, options.out);
    if (report.interrupted) printInterrupted("bench-gather");
}

} // namespace lightskin::bench
