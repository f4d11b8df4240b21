// `lightskin bench`: the speed/accuracy trade-off of LightSkin. Sweeps one knob at a time
// around a default configuration (sparse points per model, VAL stride, K_cache, channels, output
// resolution, mesh size, adaptive mode) on the synthetic mixed-reality scene of BenchScene.h and, for
// every configuration, measures GPU stage times (timer queries) and CPU times (median of several frames
// after a warm-up) and the error of the indirect light in linear space against (a) the brute force on
// the same VALs and G-buffer and (b) the Embree ground truth with visibility. Then temporal stability
// (flicker at re-projected surface points) on three sequences. Writes CSV, JSON, a plot and a Markdown
// table (optionally regenerated into docs/BENCHMARKS.md). A benchmark, not a test: `--quick` is the
// CI smoke run (tests/bench) and checks that the error falls as sparse points or VALs grow.
#include <lightskin/bench/BenchReport.h>
#include <lightskin/bench/BenchScene.h>
#include <lightskin/bench/SweepBench.h>
#include <lightskin/core/CpuTime.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/gi/Techniques.h>
#include <lightskin/gi/bruteforce/BruteForceIllumination.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gi/common/SparsePointSampler.h>
#include <lightskin/gi/common/ValGenerator.h>
#include <lightskin/gi/lightskin/CpuLightSkin.h>
#include <lightskin/gi/lightskin/LightSkinIllumination.h>
#include <lightskin/gi/prt/MultiscalePrt.h>
#include <lightskin/gi/reference/RayTracedGroundTruth.h>
#include <lightskin/gi/volumes/ImperfectVolumes.h>
#include <lightskin/gl/Context.h>
#include <lightskin/gl/DebugOutput.h>
#include <lightskin/gl/GpuTimer.h>

#include <epoxy/gl.h>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <span>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

namespace lightskin::bench {

namespace {

using namespace bench;
using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

double msSince(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// CPU time of the whole process in ms (all threads: llvmpipe's rasteriser threads are ours). On a
/// machine shared with other jobs, CPU time is what a frame costs; wall time includes waiting.
int parseInt(const std::string& s, const char* option) {
    try {
        std::size_t used = 0;
        const int v = std::stoi(s, &used);
        if (used == s.size() && v > 0) return v;
    } catch (const std::exception&) {
    }
    throw Error(option, std::nullopt, "expected a positive integer, got '" + s + "'");
}

void applyQuick(SweepBenchOptions& o) {
    o.sparse = "64,256,1024";
    o.strides = "8,4,2"; // the range where the VAL map's own error falls (see the checks)
    o.kCache = "";
    o.channels = "diffuse,glossy,occlusion";
    o.resolutions = "";
    o.meshes = "";
    o.adaptive = "off,on";
    o.volumes = "16:12:36:1";
    o.prt = "64:4:4:2";
    o.trees = "0.1";
    o.defaults.sparse = 256;
    o.defaults.stride = 4;
    o.defaults.channels = 1; // the checks compare like with like: brute force has no occlusion
    o.defaults.width = 320;
    o.defaults.height = 240;
    o.defaults.sphereTriangles = 8000;
    o.frames = 2;
    o.truthStride = 2; // finer than every stride of the series, so the last step is checked too
    o.truthGrid = 40;
    o.temporalFrames = 4;
    o.temporalSparse = "256";
    o.check = true;
}

/// Images of one rendered view (host copies of the G-buffer) for error and re-projection.
struct ViewImages {
    cv::Mat position, normal, albedo, specular; // CV_32FC4, GL row order (row 0 = bottom)
    cv::Mat mask;                               // CV_8UC1: covered
    std::size_t covered = 0;
};

cv::Mat readRgba(std::uint32_t texture, int width, int height) {
    cv::Mat m(height, width, CV_32FC4);
    glGetTextureImage(texture, 0, GL_RGBA, GL_FLOAT, GLsizei(m.total() * m.elemSize()), m.data);
    return m;
}

cv::Mat readRgb(std::uint32_t texture, int width, int height) {
    cv::Mat rgb;
    cv::cvtColor(readRgba(texture, width, height), rgb, cv::COLOR_RGBA2RGB);
    return rgb;
}

/// The benchmark world: meshes, GPU copies, sparse points, VAL generators, caches of references.
class World {
public:
    World(const SweepBenchOptions& options)
        : options_(options) {
        K_ = depthIntrinsics();
        renderRoom(K_, depthCameraPose(), 0.0, depth_, colour_);
        bunny_ = std::make_unique<TriangleMesh>(bunny(options.bunnyPath));
        bunnyGpu_ = std::make_unique<gi::UploadedMesh>(gi::UploadedMesh::create(*bunny_));
    }

    std::vector<gi::MeshInstance> instances(std::size_t sphereTriangles) {
        auto& entry = spheres_[sphereTriangles];
        if (!entry.first) {
            entry.first = std::make_unique<TriangleMesh>(uvSphere(0.3f, sphereTriangles));
            entry.second = std::make_unique<gi::UploadedMesh>(gi::UploadedMesh::create(*entry.first));
        }
        std::vector<gi::MeshInstance> out(2);
        out[0].meshId = std::uint32_t(1 + sphereTriangles);
        out[0].mesh = entry.first.get();
        out[0].gpu = entry.second->view();
        out[0].world_T_model = sphereWorld();
        out[0].material = sphereMaterial();
        out[1].meshId = 0;
        out[1].mesh = bunny_.get();
        out[1].gpu = bunnyGpu_->view();
        out[1].world_T_model = bunnyWorld();
        out[1].material = bunnyMaterial();
        return out;
    }

    std::size_t triangles(std::size_t sphereTriangles) {
        const auto inst = instances(sphereTriangles);
        return inst[0].mesh->triangleCount() + inst[1].mesh->triangleCount();
    }

    gi::SparsePointProvider provider(int count) {
        return [this, count](const gi::MeshInstance& instance) {
            const auto key = std::make_pair(instance.meshId, count);
            auto it = sparse_.find(key);
            if (it == sparse_.end()) {
                gi::SparsePointSettings s;
                s.pointCount = count;
                s.refine = false;
                it = sparse_.emplace(key, gi::sampleSparsePoints(*instance.mesh, s, "bench mesh")).first;
            }
            return it->second;
        };
    }

    gi::ValGenerator& generator(int stride) {
        auto it = generators_.find(stride);
        if (it == generators_.end()) {
            gi::ValGeneratorSettings s;
            s.stride = stride;
            s.exposure = 2.0f;
            it = generators_.emplace(stride, gi::ValGenerator::create(K_.width, K_.height, s)).first;
        }
        return it->second;
    }

    /// VALs of the static frame at `stride` (generated now; the view stays valid until the next call
    /// for the same stride). `gpuMs` receives the generation's GPU time.
    gi::ValSetView vals(int stride, double* gpuMs = nullptr, const cv::Mat* depth = nullptr,
                        const cv::Mat* colour = nullptr, const Pose* pose = nullptr) {
        if (!timer_.has_value()) timer_ = gl::GpuStageTimer::create(1);
        timer_->beginFrame();
        timer_->begin("vals");
        const gi::ValSetView set = generator(stride).generate(depth ? *depth : depth_, 1.0, colour ? *colour : colour_,
                                                              K_, pose ? *pose : depthCameraPose());
        timer_->end();
        timer_->collect(stages_);
        if (gpuMs) *gpuMs = stages_.empty() ? 0.0 : stages_[0].milliseconds;
        return set;
    }

    gi::SimpleGBuffer& gbuffer(int width, int height) {
        auto it = gbuffers_.find({width, height});
        if (it == gbuffers_.end())
            it = gbuffers_.emplace(std::make_pair(width, height), gi::SimpleGBuffer::create(width, height)).first;
        return it->second;
    }

    gl::Texture& target(int width, int height) {
        auto it = targets_.find({width, height});
        if (it == targets_.end())
            it =
                targets_.emplace(std::make_pair(width, height), gl::Texture::create2D(GL_RGBA32F, width, height)).first;
        return it->second;
    }

    ViewImages renderView(const std::vector<gi::MeshInstance>& inst, int width, int height, const glm::mat4& clip) {
        auto& g = gbuffer(width, height);
        g.render(inst, clip);
        const gi::GBufferView v = g.view();
        ViewImages images;
        images.position = readRgba(v.worldPosition, width, height);
        images.normal = readRgba(v.worldNormal, width, height);
        images.albedo = readRgba(v.diffuseAlbedo, width, height);
        images.specular = readRgba(v.specular, width, height);
        images.mask = cv::Mat(height, width, CV_8UC1, cv::Scalar(0));
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x)
                if (images.position.at<cv::Vec4f>(y, x)[3] != 0.0f) {
                    images.mask.at<std::uint8_t>(y, x) = 255;
                    ++images.covered;
                }
        return images;
    }

    /// Brute force (GPU) on the static frame's VALs at `stride`, cached.
    struct BruteImage {
        cv::Mat image;
        double ms = 0.0;
        std::size_t vals = 0;
        bool valid = false;
    };
    const BruteImage& brute(const Config& c, bool glossy, std::size_t covered) {
        const auto key = std::make_tuple(c.stride, c.width, c.height, c.sphereTriangles, glossy);
        auto it = brute_.find(key);
        if (it != brute_.end()) return it->second;
        BruteImage b;
        const gi::ValSetView set = vals(c.stride);
        b.vals = set.count;
        if (double(set.count) * double(covered) <= options_.maxBruteInteractions) {
            std::printf("    brute force (%s, %u VALs x %zu pixels) ...", glossy ? "+glossy" : "diffuse", set.count,
                        covered);
            std::fflush(stdout);
            gi::BruteForceSettings s;
            s.glossy = glossy;
            s.valCapacity = std::max(1u, set.count);
            auto technique = gi::BruteForceIllumination::create(s);
            const auto inst = instances(c.sphereTriangles);
            technique->prepare(inst);
            auto& g = gbuffer(c.width, c.height);
            const glm::mat4 clip = viewClip(c.width, c.height);
            g.render(inst, clip);
            auto& t = target(c.width, c.height);
            // Wall time of render() + glFinish after a warm-up on a few VALs: llvmpipe's timestamp
            // queries under-report this single full-screen stage (its draws land in one binned scene and
            // the end timestamp is taken when the first tiles finish; docs/BENCHMARKS.md, "Table 1").
            technique->render({set.buffer, std::min(set.count, 16u)}, inst, g.view(), {clip, viewEye()}, t.id());
            glFinish();
            const auto start = Clock::now();
            technique->render(set, inst, g.view(), {clip, viewEye()}, t.id());
            glFinish();
            b.ms = msSince(start);
            b.image = readRgb(t.id(), c.width, c.height);
            b.valid = true;
            std::printf(" %.0f ms\n", b.ms);
        }
        return brute_.emplace(key, std::move(b)).first->second;
    }

    /// Ray-traced ground truth at a receiver grid of the view, from the truth-stride VALs, cached.
    struct Truth {
        cv::Mat diffuse, full, mask; // grid images (CV_32FC3) and CV_8UC1 mask
        int step = 1;
        std::size_t receivers = 0;
        bool valid = false;
    };
    const Truth& truth(const Config& c, const ViewImages& view) {
        const auto key = std::make_tuple(c.width, c.height, c.sphereTriangles);
        auto it = truth_.find(key);
        if (it != truth_.end()) return it->second;
        Truth t;
        t.step = std::max(1, c.width / options_.truthGrid);
        const int gw = c.width / t.step, gh = c.height / t.step;
        std::vector<gi::GroundTruthReceiver> receivers;
        std::vector<cv::Point> where;
        const glm::dvec3 eye(viewEye());
        for (int j = 0; j < gh; ++j)
            for (int i = 0; i < gw; ++i) {
                const int x = i * t.step + t.step / 2, y = j * t.step + t.step / 2;
                const cv::Vec4f p = view.position.at<cv::Vec4f>(y, x);
                if (p[3] == 0.0f) continue;
                const cv::Vec4f n = view.normal.at<cv::Vec4f>(y, x), a = view.albedo.at<cv::Vec4f>(y, x),
                                s = view.specular.at<cv::Vec4f>(y, x);
                gi::GroundTruthReceiver r;
                r.position = glm::dvec3(p[0], p[1], p[2]);
                r.normal = glm::normalize(glm::dvec3(n[0], n[1], n[2]));
                r.toViewer = glm::normalize(eye - r.position);
                r.material.diffuseAlbedo = glm::vec3(a[0], a[1], a[2]);
                r.material.specularAlbedo = glm::vec3(s[0], s[1], s[2]);
                r.material.specularExponent = std::max(1.0f, s[3]);
                receivers.push_back(r);
                where.emplace_back(i, j);
            }
        gi::ValGenerator& gen = generator(options_.truthStride);
        vals(options_.truthStride);
        const std::vector<gi::VirtualAreaLight> truthVals = gen.downloadVals();
        const double rays = double(receivers.size()) * double(truthVals.size());
        if (rays <= options_.maxTruthRays) {
            std::printf("    ground truth (Embree, %zu receivers x %zu VALs) ...", receivers.size(), truthVals.size());
            std::fflush(stdout);
            const auto start = Clock::now();
            const auto inst = instances(c.sphereTriangles);
            std::vector<gi::GroundTruthMesh> meshes;
            for (const auto& m : inst) meshes.push_back({m.mesh, glm::dmat4(m.world_T_model)});
            const auto rt = gi::RayTracedGroundTruth::create(meshes);
            std::vector<gi::GroundTruthResult> results(receivers.size());
            gi::GroundTruthSettings settings;
            settings.discRings = settings.discSectors = 1; // disc-centre visibility, the paper's disc form factor
            rt.compute(truthVals, receivers, results, settings);
            t.diffuse = cv::Mat(gh, gw, CV_32FC3, cv::Scalar::all(0));
            t.full = cv::Mat(gh, gw, CV_32FC3, cv::Scalar::all(0));
            t.mask = cv::Mat(gh, gw, CV_8UC1, cv::Scalar(0));
            for (std::size_t k = 0; k < receivers.size(); ++k) {
                const glm::dvec3 d =
                    glm::dvec3(receivers[k].material.diffuseAlbedo) / std::numbers::pi * results[k].irradiance;
                t.diffuse.at<cv::Vec3f>(where[k]) = cv::Vec3f(float(d.x), float(d.y), float(d.z));
                t.full.at<cv::Vec3f>(where[k]) =
                    cv::Vec3f(float(results[k].radiance.x), float(results[k].radiance.y), float(results[k].radiance.z));
                t.mask.at<std::uint8_t>(where[k]) = 255;
            }
            t.receivers = receivers.size();
            t.valid = true;
            std::printf(" %.1f s\n", msSince(start) / 1000.0);
        }
        return truth_.emplace(key, std::move(t)).first->second;
    }

    const CameraIntrinsics& intrinsics() const { return K_; }

    /// VALs of a mapWidth x mapHeight VAL map of the static frame. Maps that divide the 640x480 depth
    /// frame by a common stride (160x120, 320x240, 640x480: the Kinect setups) are that frame at that
    /// stride; any other size (the paper's 16k / 64k / 512k VALs) is the same room rendered by the
    /// same camera with intrinsics scaled to mapWidth x mapHeight, at stride 1. The view stays valid
    /// until the next call for the same map.
    gi::ValSetView valMap(int mapWidth, int mapHeight) {
        if (K_.width % mapWidth == 0 && K_.height % mapHeight == 0 && K_.width / mapWidth == K_.height / mapHeight)
            return vals(K_.width / mapWidth);
        auto it = maps_.find({mapWidth, mapHeight});
        if (it == maps_.end()) {
            ScaledMap m;
            m.K = K_.scaledTo(mapWidth, mapHeight);
            renderRoom(m.K, depthCameraPose(), 0.0, m.depth, m.colour);
            gi::ValGeneratorSettings s;
            s.stride = 1;
            s.exposure = 2.0f;
            m.generator.emplace(gi::ValGenerator::create(mapWidth, mapHeight, s));
            it = maps_.emplace(std::make_pair(mapWidth, mapHeight), std::move(m)).first;
        }
        ScaledMap& m = it->second;
        return m.generator->generate(m.depth, 1.0, m.colour, m.K, depthCameraPose());
    }

private:
    struct ScaledMap {
        CameraIntrinsics K;
        cv::Mat depth, colour;
        std::optional<gi::ValGenerator> generator;
    };
    std::map<std::pair<int, int>, ScaledMap> maps_;
    const SweepBenchOptions& options_;
    CameraIntrinsics K_;
    cv::Mat depth_, colour_;
    std::unique_ptr<TriangleMesh> bunny_;
    std::unique_ptr<gi::UploadedMesh> bunnyGpu_;
    std::map<std::size_t, std::pair<std::unique_ptr<TriangleMesh>, std::unique_ptr<gi::UploadedMesh>>> spheres_;
    std::map<std::pair<std::uint32_t, int>, gi::SparsePointSet> sparse_;
    std::map<int, gi::ValGenerator> generators_;
    std::map<std::pair<int, int>, gi::SimpleGBuffer> gbuffers_;
    std::map<std::pair<int, int>, gl::Texture> targets_;
    std::map<std::tuple<int, int, int, std::size_t, bool>, BruteImage> brute_;
    std::map<std::tuple<int, int, std::size_t>, Truth> truth_;
    std::optional<gl::GpuStageTimer> timer_;
    std::vector<gl::StageTime> stages_;
};

gi::LightSkinSettings settingsFor(const Config& c, std::uint32_t vals) {
    gi::LightSkinSettings s;
    s.kCache = c.kCache;
    s.glossy = c.channels >= 2;
    s.occlusion = c.channels >= 3;
    s.adaptive = c.adaptive;
    s.valTreeThreshold = c.valTree;
    s.valCapacity = std::max(1u, vals);
    return s;
}

cv::Mat sampleGrid(const cv::Mat& image, int step, int gw, int gh) {
    cv::Mat out(gh, gw, CV_32FC3);
    for (int j = 0; j < gh; ++j)
        for (int i = 0; i < gw; ++i)
            out.at<cv::Vec3f>(j, i) = image.at<cv::Vec3f>(j * step + step / 2, i * step + step / 2);
    return out;
}

/// Largest value of the reference (uncovered pixels are 0, so this is the maximum over the covered ones).
double maxValue(const cv::Mat& image) {
    double hi = 0.0;
    cv::minMaxLoc(image.reshape(1), nullptr, &hi);
    return hi > 0.0 ? hi : 1.0;
}

eval::ImageError compare(const cv::Mat& image, const cv::Mat& reference, const cv::Mat& mask) {
    eval::ImageErrorOptions o;
    o.ssimPeak = maxValue(reference);
    o.mask = mask;
    return eval::compareImages(image, reference, o);
}

RunResult runConfig(World& world, const SweepBenchOptions& options, const Config& c) {
    RunResult r;
    r.config = c;
    const auto inst = world.instances(c.sphereTriangles);
    r.triangles = world.triangles(c.sphereTriangles);
    const glm::mat4 clip = viewClip(c.width, c.height);
    const ViewImages view = world.renderView(inst, c.width, c.height, clip);
    r.covered = view.covered;
    const bool glossy = c.channels >= 2;
    const auto& brute = world.brute(c, glossy, view.covered);
    const auto& truth = world.truth(c, view);

    gi::ValSetView set = world.vals(c.stride);
    r.vals = set.count;
    const auto prepStart = Clock::now();
    r.backend = gi::toString(c.backend);
    // Both backends share the technique's settings and interface; the CPU backend's stage times are the
    // wall times of its CPU stages plus the GPU time of its shading pass, so their sum is its frame time.
    gi::TechniqueConfig config;
    config.technique = c.technique;
    config.backend = c.backend;
    config.lightSkin = settingsFor(c, set.count);
    config.imperfectVolumes = c.volumes;
    config.multiscalePrt = c.prt;
    if (c.technique == gi::Technique::ImperfectVolumes) r.method = "imperfect volumes";
    if (c.technique == gi::Technique::MultiscalePrt) {
        r.method = "multiscale-prt";                // prepareMs: its precompute, or the cache load with --cache-dir
        r.backend = gi::toString(gi::Backend::Cpu); // its per-frame part runs on the CPU (the shading pass on GL)
    }
    std::unique_ptr<gi::IndirectIllumination> technique = gi::createTechnique(config, world.provider(c.sparse));
    technique->prepare(inst);
    r.prepareMs = msSince(prepStart);
    auto& g = world.gbuffer(c.width, c.height);
    g.render(inst, clip);
    auto& target = world.target(c.width, c.height);
    std::vector<double> gpu, cpu, valsMs;
    std::map<std::string, std::vector<double>> stageTimes;
    std::vector<std::string> order;
    std::vector<gl::StageTime> stages;
    for (int f = 0; f <= options.frames; ++f) { // frame 0: warm-up
        double vMs = 0.0;
        const auto start = Clock::now();
        set = world.vals(c.stride, &vMs);
        technique->render(set, inst, g.view(), {clip, viewEye()}, target.id());
        glFinish();
        const double wall = msSince(start);
        technique->lastStageTimes(stages);
        if (f == 0) continue;
        double total = 0.0;
        for (const auto& s : stages) {
            if (std::find(order.begin(), order.end(), s.name) == order.end()) order.push_back(s.name);
            stageTimes[s.name].push_back(s.milliseconds);
            total += s.milliseconds;
        }
        gpu.push_back(total);
        cpu.push_back(wall);
        valsMs.push_back(vMs);
    }
    r.gpuMs = median(gpu);
    r.cpuMs = median(cpu);
    r.valsMs = median(valsMs);
    for (const auto& name : order) r.stages.emplace_back(name, median(stageTimes[name]));
    const cv::Mat image = readRgb(target.id(), c.width, c.height);
    if (brute.valid) {
        r.bruteMs = brute.ms;
        r.vsBrute = compare(image, brute.image, view.mask);
    }
    if (truth.valid) {
        const cv::Mat grid = sampleGrid(image, truth.step, truth.diffuse.cols, truth.diffuse.rows);
        r.vsTruth = compare(grid, glossy ? truth.full : truth.diffuse, truth.mask);
        r.truthReceivers = truth.receivers;
    }
    // Only where output and mesh are the default's (the VAL-stride question; saves the most expensive
    // brute-force runs at large outputs and meshes).
    if (c.width == options.defaults.width && c.height == options.defaults.height &&
        c.sphereTriangles == options.defaults.sphereTriangles) {
        Config fine = c;
        fine.stride = options.truthStride;
        const auto& fineBrute = world.brute(fine, glossy, view.covered);
        if (fineBrute.valid) r.vsFineBrute = compare(image, fineBrute.image, view.mask);
        if (fineBrute.valid && brute.valid) r.bruteVsFineBrute = compare(brute.image, fineBrute.image, view.mask);
    }
    return r;
}

/// The brute force's own error against the ground truth (default configuration's inputs).
RunResult bruteRow(World& world, const Config& c) {
    RunResult r;
    r.config = c;
    r.isBrute = true;
    r.method = "brute force";
    const auto inst = world.instances(c.sphereTriangles);
    r.triangles = world.triangles(c.sphereTriangles);
    const ViewImages view = world.renderView(inst, c.width, c.height, viewClip(c.width, c.height));
    r.covered = view.covered;
    const bool glossy = c.channels >= 2;
    const auto& brute = world.brute(c, glossy, view.covered);
    const auto& truth = world.truth(c, view);
    r.vals = brute.vals;
    if (!brute.valid) return r;
    r.bruteMs = brute.ms;
    if (truth.valid) {
        const cv::Mat grid = sampleGrid(brute.image, truth.step, truth.diffuse.cols, truth.diffuse.rows);
        r.vsTruth = compare(grid, glossy ? truth.full : truth.diffuse, truth.mask);
        r.truthReceivers = truth.receivers;
    }
    return r;
}

std::vector<Config> buildSweep(const SweepBenchOptions& o) {
    std::vector<Config> configs;
    Config d = o.defaults;
    d.isDefault = true;
    configs.push_back(d);
    const auto add = [&](const std::string& axis, const std::string& value, auto mutate) {
        Config c = o.defaults;
        mutate(c);
        c.axis = axis;
        c.value = value;
        Config probe = c;
        probe.axis = "default";
        probe.value = "-";
        const bool same = probe.sparse == d.sparse && probe.stride == d.stride && probe.kCache == d.kCache &&
                          probe.channels == d.channels && probe.width == d.width && probe.height == d.height &&
                          probe.sphereTriangles == d.sphereTriangles && probe.adaptive == d.adaptive &&
                          probe.backend == d.backend && probe.technique == d.technique && probe.valTree == d.valTree;
        if (!same) configs.push_back(c);
    };
    for (int s : splitList<int>(o.sparse, [](const std::string& x) { return parseInt(x, "--sparse"); }))
        add("sparse", std::to_string(s), [s](Config& c) { c.sparse = s; });
    for (int s : splitList<int>(o.strides, [](const std::string& x) { return parseInt(x, "--strides"); }))
        add("stride", std::to_string(s), [s](Config& c) { c.stride = s; });
    for (int k : splitList<int>(o.kCache, [](const std::string& x) { return parseInt(x, "--kcache"); }))
        add("kcache", std::to_string(k), [k](Config& c) { c.kCache = k; });
    for (const std::string& ch : splitList<std::string>(o.channels, [](const std::string& x) { return x; })) {
        const int n = ch == "diffuse" ? 1 : ch == "glossy" ? 2 : ch == "occlusion" ? 3 : 0;
        if (n == 0) throw Error("--channels", std::nullopt, "expected diffuse, glossy or occlusion, got '" + ch + "'");
        add("channels", channelName(n), [n](Config& c) { c.channels = n; });
    }
    for (const std::string& res : splitList<std::string>(o.resolutions, [](const std::string& x) { return x; })) {
        int w = 0, h = 0;
        if (std::sscanf(res.c_str(), "%dx%d", &w, &h) != 2 || w < 16 || h < 16 || w > 8192 || h > 8192)
            throw Error("--resolutions", std::nullopt, "expected WIDTHxHEIGHT, got '" + res + "'");
        add("output", res, [w, h](Config& c) {
            c.width = w;
            c.height = h;
        });
    }
    for (int m : splitList<int>(o.meshes, [](const std::string& x) { return parseInt(x, "--meshes"); }))
        add("mesh", std::to_string(m), [m](Config& c) { c.sphereTriangles = std::size_t(m); });
    for (const std::string& a : splitList<std::string>(o.adaptive, [](const std::string& x) { return x; })) {
        if (a != "on" && a != "off") throw Error("--adaptive", std::nullopt, "expected on or off, got '" + a + "'");
        add("adaptive", a, [a](Config& c) { c.adaptive = a == "on"; });
    }
    for (const std::string& b : splitList<std::string>(o.backends, [](const std::string& x) { return x; })) {
        const std::optional<gi::Backend> backend = gi::parseBackend(b);
        if (!backend)
            throw Error("--backends", std::nullopt, "expected " + gi::backendNames(false) + ", got '" + b + "'");
        add("backend", b, [backend](Config& c) { c.backend = *backend; });
    }
    for (const std::string& t : splitList<std::string>(o.trees, [](const std::string& x) { return x; })) {
        char* end = nullptr;
        const float threshold = std::strtof(t.c_str(), &end);
        if (end == t.c_str() || *end != '\0' || !(threshold >= 0.0f) || !std::isfinite(threshold))
            throw Error("--trees", std::nullopt, "expected a threshold >= 0, got '" + t + "'");
        add("tree", t, [threshold](Config& c) { c.valTree = threshold; });
    }
    for (const std::string& v : splitList<std::string>(o.volumes, [](const std::string& x) { return x; })) {
        gi::ImperfectVolumesSettings s;
        if (std::sscanf(v.c_str(), "%d:%d:%d:%d", &s.resolution, &s.pointsPerTriangle, &s.raysPerVoxel, &s.bounces) !=
            4)
            throw Error("--volumes", std::nullopt, "expected resolution:points:rays:bounces, got '" + v + "'");
        gi::validate(s);
        add("volumes", v, [s](Config& c) {
            c.technique = gi::Technique::ImperfectVolumes;
            c.volumes = s;
            c.channels = 1;
        });
    }
    for (const std::string& v : splitList<std::string>(o.prt, [](const std::string& x) { return x; })) {
        gi::MultiscalePrtSettings s;
        const int fields = std::sscanf(v.c_str(), "%d:%d:%d:%d:%d", &s.entryPoints, &s.walksPerEntry, &s.clusters,
                                       &s.basisVectors, &s.directGatherPoints);
        if (fields != 4 && fields != 5)
            throw Error("--prt", std::nullopt, "expected entries:walks:clusters:D[:gather-points], got '" + v + "'");
        s.cacheDirectory = o.prtCacheDir;
        gi::validate(s);
        add("prt", v, [s](Config& c) {
            c.technique = gi::Technique::MultiscalePrt;
            c.prt = s;
            c.channels = 1;
        });
    }
    return configs;
}

// ---- temporal stability ------------------------------------------------------------------------

struct Track {
    std::vector<std::vector<float>> ours; // [technique][frame * points + point] (NaN = not visible)
    std::vector<float> reference;
};

void sampleTracked(const std::vector<glm::vec3>& points, const glm::mat4& clip, const ViewImages& view,
                   const cv::Mat& image, float tolerance, std::vector<float>& out) {
    const int w = view.position.cols, h = view.position.rows;
    for (const glm::vec3& p : points) {
        const glm::vec4 c = clip * glm::vec4(p, 1.0f);
        float value = std::nanf("");
        if (c.w > 0.0f) {
            const int x = int(std::floor((c.x / c.w * 0.5f + 0.5f) * float(w)));
            const int y = int(std::floor((c.y / c.w * 0.5f + 0.5f) * float(h)));
            if (x >= 0 && y >= 0 && x < w && y < h) {
                const cv::Vec4f g = view.position.at<cv::Vec4f>(y, x);
                if (g[3] != 0.0f && glm::length(glm::vec3(g[0], g[1], g[2]) - p) < tolerance) {
                    const cv::Vec3f v = image.at<cv::Vec3f>(y, x);
                    value = (v[0] + v[1] + v[2]) / 3.0f;
                }
            }
        }
        out.push_back(value);
    }
}

/// The flicker rows of the three sequences; a stop skips the sequences not started.
std::vector<TemporalResult> runTemporal(World& world, const SweepBenchOptions& options, StopCheck& stop) {
    const int width = 320, height = 240, n = std::max(2, options.temporalFrames), stride = options.temporalStride;
    const auto sparseList =
        splitList<int>(options.temporalSparse, [](const std::string& x) { return parseInt(x, "--temporal-sparse"); });
    const auto inst = world.instances(options.defaults.sphereTriangles);
    // Tracked surface points: every k-th vertex of both meshes, in world space.
    std::vector<glm::vec3> points;
    for (const auto& m : inst) {
        const std::size_t step = std::max<std::size_t>(1, m.mesh->vertexCount() / 1500);
        for (std::size_t i = 0; i < m.mesh->vertexCount(); i += step)
            points.emplace_back(m.world_T_model * glm::vec4(m.mesh->positions[i], 1.0f));
    }
    std::vector<TemporalResult> results;
    for (const std::string sequence : {"camera", "light", "edges"}) {
        if (stop()) break;
        std::printf("  temporal sequence '%s' (%d frames, %zu tracked points)\n", sequence.c_str(), n, points.size());
        std::fflush(stdout);
        std::vector<std::unique_ptr<gi::IndirectIllumination>> techniques;
        Config c = options.defaults;
        c.width = width;
        c.height = height;
        c.stride = stride;
        // Imperfect volumes at the paper's settings, without and with the temporal
        // mitigation (jitter + temporal blend), after the LightSkin entries.
        const std::vector<std::pair<std::string, gi::ImperfectVolumesSettings>> volumeVariants = [] {
            gi::ImperfectVolumesSettings paper, mitigated;
            mitigated.jitter = true;
            mitigated.temporalBlend = 0.75f;
            return std::vector<std::pair<std::string, gi::ImperfectVolumesSettings>>{
                {"imperfect volumes, 64^3/12/100, diffuse", paper},
                {"imperfect volumes, 64^3/12/100, jitter + blend 0.75", mitigated}};
        }();
        std::vector<std::vector<float>> ours(sparseList.size() + volumeVariants.size());
        std::vector<float> reference;
        gi::BruteForceSettings bs;
        bs.glossy = false; // diffuse on both sides: the true change in the camera sequence is then 0
        bs.valCapacity = 1u << 16;
        auto brute = gi::BruteForceIllumination::create(bs);
        brute->prepare(inst);
        for (int s : sparseList) {
            c.sparse = s;
            gi::LightSkinSettings settings = settingsFor(c, 1u << 16);
            settings.glossy = false; // view-independent: see bs.glossy
            auto t = gi::LightSkinIllumination::create(settings, world.provider(s));
            t->prepare(inst);
            techniques.push_back(std::move(t));
        }
        for (const auto& variant : volumeVariants) {
            techniques.push_back(gi::ImperfectVolumes::create(variant.second));
            techniques.back()->prepare(inst);
        }
        auto& g = world.gbuffer(width, height);
        auto& target = world.target(width, height);
        cv::Mat depth, colour;
        for (int f = 0; f < n; ++f) {
            const double phase = double(f) / double(n - 1);
            const bool moveCamera = sequence == "camera";
            const double spotX = sequence == "light" ? -1.0 + 2.0 * phase : 0.0;
            const Pose pose = depthCameraPose(sequence == "edges" ? 0.15 * phase : 0.0);
            renderRoom(world.intrinsics(), pose, spotX, depth, colour);
            const gi::ValSetView set = world.vals(stride, nullptr, &depth, &colour, &pose);
            const glm::mat4 clip = moveCamera ? viewClip(width, height, f, n) : viewClip(width, height);
            const gi::ViewParameters viewParameters{clip, moveCamera ? viewEye(f, n) : viewEye()};
            const ViewImages view = world.renderView(inst, width, height, clip);
            brute->render(set, inst, g.view(), viewParameters, target.id());
            sampleTracked(points, clip, view, readRgb(target.id(), width, height), options.temporalTolerance,
                          reference);
            for (std::size_t k = 0; k < techniques.size(); ++k) {
                techniques[k]->render(set, inst, g.view(), viewParameters, target.id());
                sampleTracked(points, clip, view, readRgb(target.id(), width, height), options.temporalTolerance,
                              ours[k]);
            }
        }
        // Mean reference level over all visible samples.
        double level = 0.0;
        std::size_t levelCount = 0;
        for (float v : reference)
            if (!std::isnan(v)) {
                level += double(v);
                ++levelCount;
            }
        level = levelCount ? level / double(levelCount) : 1.0;
        const auto flickerOf = [&](const std::vector<float>& a, const std::vector<float>* refSeries,
                                   std::size_t& samples) {
            double sum = 0.0;
            samples = 0;
            for (int f = 1; f < n; ++f)
                for (std::size_t p = 0; p < points.size(); ++p) {
                    const std::size_t i0 = std::size_t(f - 1) * points.size() + p,
                                      i1 = std::size_t(f) * points.size() + p;
                    if (std::isnan(a[i0]) || std::isnan(a[i1]) || std::isnan(reference[i0]) ||
                        std::isnan(reference[i1]))
                        continue;
                    double d = double(a[i1]) - double(a[i0]);
                    if (refSeries) d -= double((*refSeries)[i1]) - double((*refSeries)[i0]);
                    sum += d * d;
                    ++samples;
                }
            return samples ? std::sqrt(sum / double(samples)) / level : 0.0;
        };
        std::size_t samples = 0;
        const double referenceFlicker = flickerOf(reference, nullptr, samples);
        results.push_back({sequence, "brute force (reference, diffuse)", n, samples, referenceFlicker, referenceFlicker,
                           0.0, "brute force", std::string(gi::toString(gi::Backend::Gl))});
        for (std::size_t k = 0; k < techniques.size(); ++k) {
            TemporalResult t;
            t.sequence = sequence;
            const bool volumes = k >= sparseList.size();
            t.technique = volumes ? volumeVariants[k - sparseList.size()].first
                                  : "lightskin, " + std::to_string(sparseList[k]) + " sparse/model, diffuse" +
                                        (c.channels >= 3 ? " + occlusion" : "");
            if (volumes) t.method = "imperfect volumes";
            t.frames = n;
            t.flicker = flickerOf(ours[k], nullptr, samples);
            t.excessFlicker = flickerOf(ours[k], &reference, samples);
            t.referenceFlicker = referenceFlicker;
            t.pointPairs = samples;
            results.push_back(t);
            std::printf("    %-45s flicker %.4f (reference %.4f), excess %.4f, %zu samples\n", t.technique.c_str(),
                        t.flicker, t.referenceFlicker, t.excessFlicker, samples);
        }
        std::fflush(stdout);
    }
    return results;
}

// ---- checks (quick mode) -------------------------------------------------------------------------

/// What a monotonicity check reads from each run.
enum class ErrorSeries {
    SameVals,       ///< LightSkin against the brute force on the same VALs (the sparse-point approximation)
    FineBrute,      ///< LightSkin against the brute force on the finest VAL map (stride and approximation)
    Discretisation, ///< the brute force on the run's VAL map against the one on the finest (the stride alone)
    Truth,          ///< LightSkin against the ray-traced ground truth
};

CheckResult monotone(const std::vector<RunResult>& runs, const std::string& axis, ErrorSeries what, double tolerance) {
    std::vector<std::pair<double, double>> series; // (knob growing, error)
    for (const auto& r : runs) {
        if (r.isBrute) continue;
        const bool onAxis = r.config.axis == axis || r.config.isDefault;
        if (!onAxis) continue;
        const auto& e = what == ErrorSeries::Truth            ? r.vsTruth
                        : what == ErrorSeries::FineBrute      ? r.vsFineBrute
                        : what == ErrorSeries::Discretisation ? r.bruteVsFineBrute
                                                              : r.vsBrute;
        if (!e) continue;
        const double knob = axis == "sparse" ? double(r.config.sparse) : -double(r.config.stride);
        if (r.config.isDefault &&
            std::any_of(series.begin(), series.end(), [&](const auto& s) { return s.first == knob; }))
            continue;
        series.emplace_back(knob, e->relativeMse);
    }
    std::sort(series.begin(), series.end());
    CheckResult c;
    c.name = "error " +
             std::string(what == ErrorSeries::Truth            ? "vs ground truth"
                         : what == ErrorSeries::FineBrute      ? "vs brute force on the finest VALs"
                         : what == ErrorSeries::Discretisation ? "of the brute force vs itself on the finest VALs"
                                                               : "vs brute force (same VALs)") +
             " falls as " + (axis == "sparse" ? "sparse points grow" : "VALs grow (stride shrinks)");
    c.passed = series.size() >= 2;
    std::ostringstream detail;
    detail << "rel. MSE";
    for (std::size_t i = 0; i < series.size(); ++i) {
        detail << (i ? " -> " : " ") << series[i].second;
        if (i > 0 && series[i].second > series[i - 1].second * (1.0 + tolerance)) c.passed = false;
    }
    detail << " (each at most " << 100.0 * tolerance << " % above the previous)";
    c.detail = detail.str();
    return c;
}

// ---- Blender Cycles reference export (scripts/blender_reference.py) ------------------------------

void writeRaw(const cv::Mat& glImage, const std::string& path) {
    cv::Mat flipped;
    cv::flip(glImage, flipped, 0); // GL rows are bottom-up; the file is top-down like Blender's view
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(flipped.data), std::streamsize(flipped.total() * flipped.elemSize()));
    if (!out) throw Error(path, std::nullopt, "cannot write");
}

/// Writes the default view of the scene (VAL discs with their radiance, the two meshes in world
/// space with their materials: diffuse albedo, f_s, Phong k, and eq. 5's c; the camera) as
/// scene.json, and our images of it as raw float32 RGB (top-down rows): LightSkin (diffuse + glossy +
/// occlusion), brute force (diffuse + glossy), ground truth (diffuse + glossy, with visibility, every
/// covered pixel), plus the coverage mask.
void exportBlender(World& world, const SweepBenchOptions& options) {
    const std::string dir = options.exportBlender;
    std::filesystem::create_directories(dir);
    Config c = options.defaults;
    c.channels = 3; // diffuse + glossy + occlusion (also set explicitly below)
    const int width = c.width, height = c.height;
    auto inst = world.instances(c.sphereTriangles);
    const glm::mat4 clip = viewClip(width, height);
    const ViewImages view = world.renderView(inst, width, height, clip);
    world.vals(c.stride);
    const std::vector<gi::VirtualAreaLight> vals = world.generator(c.stride).downloadVals();
    nlohmann::json j;
    j["width"] = width;
    j["height"] = height;
    j["fovy_radians"] = 0.75;
    const glm::vec3 eye = viewEye(), target = viewTarget();
    j["eye"] = {eye.x, eye.y, eye.z};
    j["target"] = {target.x, target.y, target.z};
    j["val_stride"] = c.stride;
    const float glossyC = gi::LightSkinSettings{}.cParameter; // the same c for all three images
    j["glossy_c"] = glossyC;
    for (const auto& v : vals) {
        const glm::vec3 radiance = v.flux / (std::numbers::pi_v<float> * v.area);
        j["vals"].push_back({v.position.x, v.position.y, v.position.z, v.normal.x, v.normal.y, v.normal.z, v.area,
                             radiance.x, radiance.y, radiance.z});
    }
    for (const auto& m : inst) {
        nlohmann::json mesh;
        for (std::size_t i = 0; i < m.mesh->vertexCount(); ++i) {
            const glm::vec3 p = m.world_T_model * glm::vec4(m.mesh->positions[i], 1.0f);
            const glm::vec3 n = glm::normalize(glm::mat3(m.world_T_model) * m.mesh->normals[i]);
            mesh["positions"].push_back({p.x, p.y, p.z});
            mesh["normals"].push_back({n.x, n.y, n.z});
        }
        mesh["indices"] = m.mesh->indices;
        mesh["albedo"] = {m.material.diffuseAlbedo.x, m.material.diffuseAlbedo.y, m.material.diffuseAlbedo.z};
        mesh["specular_albedo"] = {m.material.specularAlbedo.x, m.material.specularAlbedo.y,
                                   m.material.specularAlbedo.z};
        mesh["specular_exponent"] = m.material.specularExponent;
        j["meshes"].push_back(mesh);
    }
    std::ofstream(dir + "/scene.json") << j.dump() << "\n";

    auto& g = world.gbuffer(width, height);
    auto& tex = world.target(width, height);
    const gi::ValSetView set = world.vals(c.stride);
    gi::LightSkinSettings s = settingsFor(c, set.count);
    s.glossy = true;
    s.cParameter = glossyC;
    s.occlusion = true;
    auto technique = gi::LightSkinIllumination::create(s, world.provider(c.sparse));
    technique->prepare(inst);
    technique->render(set, inst, g.view(), {clip, eye}, tex.id());
    writeRaw(readRgb(tex.id(), width, height), dir + "/lightskin.f32");
    gi::BruteForceSettings bs;
    bs.glossy = true;
    bs.cParameter = glossyC;
    bs.valCapacity = std::max(1u, set.count);
    auto brute = gi::BruteForceIllumination::create(bs);
    brute->prepare(inst);
    brute->render(set, inst, g.view(), {clip, eye}, tex.id());
    writeRaw(readRgb(tex.id(), width, height), dir + "/brute.f32");
    std::printf("exporting: ground truth at %zu pixels x %zu VALs ...\n", view.covered, vals.size());
    std::fflush(stdout);
    std::vector<gi::GroundTruthMesh> meshes;
    for (const auto& m : inst) meshes.push_back({m.mesh, glm::dmat4(m.world_T_model)});
    const auto rt = gi::RayTracedGroundTruth::create(meshes);
    std::vector<gi::GroundTruthReceiver> receivers;
    std::vector<int> where;
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            const cv::Vec4f p = view.position.at<cv::Vec4f>(y, x);
            if (p[3] == 0.0f) continue;
            const cv::Vec4f n = view.normal.at<cv::Vec4f>(y, x), a = view.albedo.at<cv::Vec4f>(y, x),
                            sp = view.specular.at<cv::Vec4f>(y, x);
            gi::GroundTruthReceiver r;
            r.position = glm::dvec3(p[0], p[1], p[2]);
            r.normal = glm::normalize(glm::dvec3(n[0], n[1], n[2]));
            r.toViewer = glm::normalize(glm::dvec3(eye) - r.position);
            r.material.diffuseAlbedo = glm::vec3(a[0], a[1], a[2]);
            r.material.specularAlbedo = glm::vec3(sp[0], sp[1], sp[2]);
            r.material.specularExponent = std::max(1.0f, sp[3]);
            receivers.push_back(r);
            where.push_back(y * width + x);
        }
    std::vector<gi::GroundTruthResult> results(receivers.size());
    gi::GroundTruthSettings gs;
    gs.discRings = gs.discSectors = 1;
    gs.glossyC = double(glossyC);
    rt.compute(vals, receivers, results, gs);
    // truth_diffuse.f32 (rho_d / pi E) lets the script check the diffuse and glossy terms separately
    // against Cycles' DiffDir and GlossDir passes.
    cv::Mat truthImage(height, width, CV_32FC3, cv::Scalar::all(0)), truthDiffuse = truthImage.clone();
    for (std::size_t k = 0; k < receivers.size(); ++k) {
        const glm::dvec3 d = results[k].radiance;
        const glm::dvec3 e = glm::dvec3(receivers[k].material.diffuseAlbedo) / std::numbers::pi * results[k].irradiance;
        truthImage.at<cv::Vec3f>(where[k] / width, where[k] % width) = cv::Vec3f(float(d.x), float(d.y), float(d.z));
        truthDiffuse.at<cv::Vec3f>(where[k] / width, where[k] % width) = cv::Vec3f(float(e.x), float(e.y), float(e.z));
    }
    writeRaw(truthImage, dir + "/truth.f32");
    writeRaw(truthDiffuse, dir + "/truth_diffuse.f32");
    cv::Mat mask;
    view.mask.convertTo(mask, CV_32F, 1.0 / 255.0);
    cv::Mat mask3;
    cv::merge(std::vector<cv::Mat>{mask, mask, mask}, mask3);
    writeRaw(mask3, dir + "/mask.f32");
    std::printf("wrote %s/scene.json (%zu VALs, 2 meshes) and lightskin/brute/truth/truth_diffuse/mask .f32 images "
                "(%dx%d RGB float32)\n",
                dir.c_str(), vals.size(), width, height);
}

// ---- Paper-style tables (--table1: the paper's Table 1 setups; --kinect: the Kinect setups) ------
//
// For every VAL map x sparse-point count x setup (diffuse; + glossy; + occlusion): the technique's GPU
// stage times (timer queries) at the full output, and the brute force on the same VALs. The brute
// force at the full output is measured only for the first VAL map (the scaling check); for every map
// it runs on a uniform pixel subset: every s-th pixel in each direction of the same full-resolution
// G-buffer (copied into an (W/s) x (H/s) G-buffer, so each subset pixel is exactly one full-resolution
// pixel), and its full-frame time is extrapolated by the covered-pixel ratio (the brute force's cost is
// VALs x covered pixels), unless it exceeds --max-brute interactions. The error is LightSkin's full-resolution image at
// the subset pixels against the subset brute force (and against the full brute force where that was measured).

struct TableSpec {
    int width = 1920, height = 1080;
    std::vector<int> sparseTotals;            ///< sparse points over both models (split evenly)
    std::vector<std::pair<int, int>> valMaps; ///< VAL map sizes
    int subset = 4;                           ///< brute force on every subset-th pixel per direction
    int frames = 1;
};

struct TableBrute {
    std::size_t vals = 0;
    double subsetMs[2] = {0.0, 0.0};                              ///< diffuse, + glossy (timer queries)
    double subsetWallMs[2] = {0.0, 0.0};                          ///< the same, wall time of render() + glFinish
    double subsetCpuMs[2] = {0.0, 0.0};                           ///< the same, process CPU time
    std::optional<double> fullMs[2], fullWallMs[2], fullCpuMs[2]; ///< measured at the full output (first map only)
    cv::Mat subsetImage[2], fullImage[2];
};

struct TableRow {
    std::pair<int, int> map;
    std::size_t vals = 0;
    std::size_t sparse = 0; ///< actual sparse points over both models
    int channels = 1;
    double gpuMs = 0.0, cpuMs = 0.0;
    std::vector<std::pair<std::string, double>> stages;
    double cpuTimeMs = 0.0;                                             ///< process CPU time of render() + glFinish
    double bruteMs = 0.0, bruteWallMs = 0.0, bruteCpuMs = 0.0;          ///< extrapolated from the subset
    std::optional<double> bruteFullMs, bruteFullWallMs, bruteFullCpuMs; ///< measured at the full output
    std::optional<eval::ImageError> vsSubset, vsFull;
    double meanRatio = 0.0; ///< total light / the brute force's, subset pixels
};

/// Sum of `image` over the mask divided by the same sum of `reference` (total light ratio).
double totalRatio(const cv::Mat& image, const cv::Mat& reference, const cv::Mat& mask) {
    cv::Mat maskedImage, maskedReference;
    image.copyTo(maskedImage, mask);
    reference.copyTo(maskedReference, mask);
    const cv::Scalar x = cv::sum(maskedImage), r = cv::sum(maskedReference);
    const double rs = r[0] + r[1] + r[2];
    return rs > 0.0 ? (x[0] + x[1] + x[2]) / rs : 0.0;
}

/// The G-buffer of every s-th pixel (at s*i + s/2) of the full-resolution host copies, as textures.
struct SubsetGBuffer {
    gl::Texture position, normal, albedo, specular;
    cv::Mat mask;
    std::size_t covered = 0;
    gi::GBufferView view;
};

cv::Mat subsample(const cv::Mat& image, int s) {
    cv::Mat out(image.rows / s, image.cols / s, image.type());
    for (int j = 0; j < out.rows; ++j)
        for (int i = 0; i < out.cols; ++i) image.row(j * s + s / 2).col(i * s + s / 2).copyTo(out.row(j).col(i));
    return out;
}

SubsetGBuffer subsetGBuffer(const ViewImages& view, int s) {
    SubsetGBuffer g;
    const auto upload = [s](const cv::Mat& full, gl::Texture& texture) {
        const cv::Mat small = subsample(full, s);
        texture = gl::Texture::create2D(GL_RGBA32F, small.cols, small.rows);
        glTextureSubImage2D(texture.id(), 0, 0, 0, small.cols, small.rows, GL_RGBA, GL_FLOAT, small.data);
        return small;
    };
    const cv::Mat position = upload(view.position, g.position);
    upload(view.normal, g.normal);
    upload(view.albedo, g.albedo);
    upload(view.specular, g.specular);
    g.mask = subsample(view.mask, s);
    g.covered = std::size_t(cv::countNonZero(g.mask));
    g.view.worldPosition = g.position.id();
    g.view.worldNormal = g.normal.id();
    g.view.diffuseAlbedo = g.albedo.id();
    g.view.specular = g.specular.id();
    g.view.width = position.cols;
    g.view.height = position.rows;
    return g;
}

/// One brute-force frame (after a warm-up on the first VALs, which compiles and binds everything):
/// {timer-query ms, wall ms of render() + glFinish, process CPU ms of the same}.
std::tuple<double, double, double> bruteFrame(const gi::ValSetView& set, bool glossy,
                                              std::span<const gi::MeshInstance> inst, const gi::GBufferView& g,
                                              const gi::ViewParameters& view, gl::Texture& target, cv::Mat& image) {
    gi::BruteForceSettings s;
    s.glossy = glossy;
    s.valCapacity = std::max(1u, set.count);
    auto technique = gi::BruteForceIllumination::create(s);
    technique->prepare(inst);
    technique->render({set.buffer, std::min(set.count, 16u)}, inst, g, view, target.id());
    glFinish();
    const double cpuStart = processCpuMs();
    const auto start = Clock::now();
    technique->render(set, inst, g, view, target.id());
    glFinish();
    const double wall = msSince(start);
    const double cpu = processCpuMs() - cpuStart;
    std::vector<gl::StageTime> stages;
    technique->lastStageTimes(stages);
    double ms = 0.0;
    for (const auto& st : stages) ms += st.milliseconds;
    image = readRgb(target.id(), g.width, g.height);
    return {ms, wall, cpu};
}

std::string mapName(const std::pair<int, int>& m) { return std::to_string(m.first) + "x" + std::to_string(m.second); }

std::string fixed(double v, int decimals) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
    return buf;
}

std::string tableMarkdown(const TableSpec& spec, const std::vector<TableRow>& rows,
                          const std::vector<TableBrute>& brutes, std::size_t coveredFull, std::size_t coveredSubset,
                          const std::string& header) {
    const double ratio = double(coveredFull) / double(coveredSubset);
    std::ostringstream md;
    md << header;
    md << "- Output " << spec.width << "x" << spec.height << ", " << coveredFull
       << " covered pixels; brute-force subset: every " << spec.subset << "th pixel per direction, " << coveredSubset
       << " covered pixels (ratio " << fixed(ratio, 3) << ").\n\n";
    md << "Brute force, ms: timer queries / wall (render() + glFinish) / process CPU time of the same. `extrapolated` "
          "= subset time x covered-pixel "
          "ratio; `measured` = the full output; scaling check = measured / extrapolated.\n\n"
          "| VAL map | VALs | diffuse, subset | diffuse, extrapolated | diffuse, measured | + glossy, subset | + "
          "glossy, "
          "extrapolated | + glossy, measured | scaling check (query; wall; CPU) "
          "|\n|---|---|---|---|---|---|---|---|---|\n";
    const auto triple = [](double q, double w, double c) {
        return fixed(q, 0) + " / " + fixed(w, 0) + " / " + fixed(c, 0);
    };
    for (std::size_t m = 0; m < brutes.size(); ++m) {
        const TableBrute& b = brutes[m];
        std::string check = "-";
        if (b.fullMs[0] && b.fullMs[1]) {
            const auto scale = [&](int k) {
                return fixed(*b.fullMs[k] / (b.subsetMs[k] * ratio), 3) + "; " +
                       fixed(*b.fullWallMs[k] / (b.subsetWallMs[k] * ratio), 3) + "; " +
                       fixed(*b.fullCpuMs[k] / (b.subsetCpuMs[k] * ratio), 3);
            };
            check = "diffuse " + scale(0) + ", + glossy " + scale(1);
        }
        md << "| " << mapName(spec.valMaps[m]) << " | " << b.vals;
        for (int k = 0; k < 2; ++k) {
            md << " | " << triple(b.subsetMs[k], b.subsetWallMs[k], b.subsetCpuMs[k]) << " | "
               << triple(b.subsetMs[k] * ratio, b.subsetWallMs[k] * ratio, b.subsetCpuMs[k] * ratio) << " | "
               << (b.fullMs[k] ? triple(*b.fullMs[k], *b.fullWallMs[k], *b.fullCpuMs[k]) : std::string("-"));
        }
        md << " | " << check << " |\n";
    }
    std::vector<std::string> stageNames;
    for (const auto& r : rows)
        for (const auto& st : r.stages)
            if (std::find(stageNames.begin(), stageNames.end(), st.first) == stageNames.end())
                stageNames.push_back(st.first);
    md << "\nLightSkin: GPU ms per stage (timer queries), total = their sum, fps = 1000 / total, wall = render() + "
          "glFinish, CPU = process CPU time of the same. "
          "Speed-up over the brute force of the same reflectance (diffuse for the diffuse setup, + glossy otherwise; "
          "the brute "
          "force has no occlusion): by timer queries, wall time and CPU time, `(x)` = extrapolated from the subset. "
          "Error against the "
          "brute force at the subset pixels (rel. MSE, SSIM, total light ratio) and at every pixel where the full "
          "brute force "
          "was measured. Gather interactions/s = sparse points x VALs / gather time.\n\n";
    md << "| VAL map | VALs | sparse | setup | total | fps | wall | CPU |";
    for (const auto& n : stageNames) md << " " << n << " |";
    md << " gather interactions/s | speed-up (query) | speed-up (wall) | speed-up (CPU) | rel. MSE vs brute | SSIM | "
          "total / brute | "
          "rel. MSE vs full brute |\n|---|---|---|---|---|---|---|---|";
    for (std::size_t i = 0; i < stageNames.size(); ++i) md << "---|";
    md << "---|---|---|---|---|---|---|---|\n";
    for (const auto& r : rows) {
        md << "| " << mapName(r.map) << " | " << r.vals << " | " << r.sparse << " | " << channelName(r.channels)
           << " | " << fixed(r.gpuMs, 1) << " | " << fixed(1000.0 / r.gpuMs, 2) << " | " << fixed(r.cpuMs, 1) << " | "
           << fixed(r.cpuTimeMs, 1) << " |";
        double gather = 0.0;
        for (const auto& n : stageNames) {
            const auto it =
                std::find_if(r.stages.begin(), r.stages.end(), [&](const auto& st) { return st.first == n; });
            if (it == r.stages.end()) {
                md << " - |";
                continue;
            }
            if (n == "gather") gather = it->second;
            md << " " << fixed(it->second, 1) << " |";
        }
        char rate[32];
        std::snprintf(rate, sizeof rate, "%.2e",
                      gather > 0.0 ? double(r.sparse) * double(r.vals) / (gather / 1000.0) : 0.0);
        md << " " << rate << " | ";
        if (r.bruteFullMs)
            md << fixed(*r.bruteFullMs / r.gpuMs, 0) << "x | " << fixed(*r.bruteFullWallMs / r.cpuMs, 0) << "x | "
               << fixed(*r.bruteFullCpuMs / r.cpuTimeMs, 0) << "x |";
        else
            md << "(" << fixed(r.bruteMs / r.gpuMs, 0) << "x) | (" << fixed(r.bruteWallMs / r.cpuMs, 0) << "x) | ("
               << fixed(r.bruteCpuMs / r.cpuTimeMs, 0) << "x) |";
        char err[160];
        if (r.vsSubset)
            std::snprintf(err, sizeof err, " %.2e | %.4f | %.4f |", r.vsSubset->relativeMse, r.vsSubset->ssim,
                          r.meanRatio);
        else
            std::snprintf(err, sizeof err, " - | - | - |");
        md << err;
        if (r.vsFull) {
            std::snprintf(err, sizeof err, " %.2e |\n", r.vsFull->relativeMse);
            md << err;
        } else {
            md << " - |\n";
        }
    }
    return md.str();
}

void runTable(const SweepBenchOptions& options, const TableSpec& spec, const std::string& title) {
    StopCheck stop(options.stopRequested);
    const auto start = Clock::now();
    auto context = gl::createHeadlessContext();
    const std::string header = "### " + title + "\n\n- Command: `" + commandLine() + "`\n- Date: " + utcNow() +
                               "\n- Machine: " + machineDescription() + "; renderer: " + context->describe() +
                               "\n- Load average (1/5/15 min) at start: " + loadAverage() + "\n";
    std::printf("%s", header.c_str());
    std::fflush(stdout);
    World world(options);
    Config base = options.defaults;
    base.width = spec.width;
    base.height = spec.height;
    const auto inst = world.instances(base.sphereTriangles);
    const glm::mat4 clip = viewClip(spec.width, spec.height);
    const gi::ViewParameters viewParams{clip, viewEye()};
    const ViewImages view = world.renderView(inst, spec.width, spec.height, clip);
    const SubsetGBuffer subset = subsetGBuffer(view, spec.subset);
    auto& gbuffer = world.gbuffer(spec.width, spec.height);
    auto& target = world.target(spec.width, spec.height);
    gl::Texture subsetTarget = gl::Texture::create2D(GL_RGBA32F, subset.view.width, subset.view.height);
    const double ratio = double(view.covered) / double(subset.covered);
    std::printf("output %dx%d: %zu covered pixels; brute-force subset %dx%d: %zu covered (ratio %.3f)\n", spec.width,
                spec.height, view.covered, subset.view.width, subset.view.height, subset.covered, ratio);

    std::vector<TableRow> rows;
    std::vector<TableBrute> brutes;
    for (std::size_t m = 0; m < spec.valMaps.size() && !stop(); ++m) {
        const auto map = spec.valMaps[m];
        gi::ValSetView set = world.valMap(map.first, map.second);
        TableBrute b;
        b.vals = set.count;
        for (int glossy = 0; glossy < 2; ++glossy) {
            std::printf("[%5.0f s] VAL map %s (%u VALs): brute force %s, subset ...", msSince(start) / 1000.0,
                        mapName(map).c_str(), set.count, glossy ? "+ glossy" : "diffuse");
            std::fflush(stdout);
            std::tie(b.subsetMs[glossy], b.subsetWallMs[glossy], b.subsetCpuMs[glossy]) =
                bruteFrame(set, glossy != 0, inst, subset.view, viewParams, subsetTarget, b.subsetImage[glossy]);
            std::printf(" %.0f ms, wall %.0f ms (extrapolated %.0f ms)", b.subsetMs[glossy], b.subsetWallMs[glossy],
                        b.subsetMs[glossy] * ratio);
            if (m == 0 &&
                double(set.count) * double(view.covered) <= options.maxBruteInteractions) { // the scaling check
                std::printf(", full ...");
                std::fflush(stdout);
                gbuffer.render(inst, clip);
                const auto [ms, wall, cpu] =
                    bruteFrame(set, glossy != 0, inst, gbuffer.view(), viewParams, target, b.fullImage[glossy]);
                b.fullMs[glossy] = ms;
                b.fullWallMs[glossy] = wall;
                b.fullCpuMs[glossy] = cpu;
                std::printf(" %.0f ms, wall %.0f ms, CPU %.0f ms (measured / extrapolated %.3f, wall %.3f, CPU %.3f)",
                            ms, wall, cpu, ms / (b.subsetMs[glossy] * ratio), wall / (b.subsetWallMs[glossy] * ratio),
                            cpu / (b.subsetCpuMs[glossy] * ratio));
            }
            std::printf("\n");
            std::fflush(stdout);
        }
        for (const int total : spec.sparseTotals) {
            for (int channels = 1; channels <= 3 && !stop(); ++channels) {
                Config c = base;
                c.sparse = std::max(1, total / 2);
                c.channels = channels;
                TableRow r;
                r.map = map;
                r.vals = set.count;
                r.channels = channels;
                const auto provider = world.provider(c.sparse);
                for (const auto& instance : inst) r.sparse += provider(instance).points.size();
                auto technique = gi::LightSkinIllumination::create(settingsFor(c, set.count), provider);
                technique->prepare(inst);
                gbuffer.render(inst, clip);
                // Warm-up on the first VALs only (compiles and binds everything; the full gather takes minutes).
                technique->render({set.buffer, std::min(set.count, 256u)}, inst, gbuffer.view(), viewParams,
                                  target.id());
                glFinish();
                std::vector<double> gpu, cpu, cpuTime;
                std::map<std::string, std::vector<double>> stageTimes;
                std::vector<std::string> order;
                std::vector<gl::StageTime> stages;
                for (int f = 0; f < spec.frames; ++f) {
                    const double cpuStart = processCpuMs();
                    const auto frameStart = Clock::now();
                    technique->render(set, inst, gbuffer.view(), viewParams, target.id());
                    glFinish();
                    cpu.push_back(msSince(frameStart));
                    cpuTime.push_back(processCpuMs() - cpuStart);
                    technique->lastStageTimes(stages);
                    double total2 = 0.0;
                    for (const auto& st : stages) {
                        if (std::find(order.begin(), order.end(), st.name) == order.end()) order.push_back(st.name);
                        stageTimes[st.name].push_back(st.milliseconds);
                        total2 += st.milliseconds;
                    }
                    gpu.push_back(total2);
                }
                r.gpuMs = median(gpu);
                r.cpuMs = median(cpu);
                r.cpuTimeMs = median(cpuTime);
                for (const auto& name : order) r.stages.emplace_back(name, median(stageTimes[name]));
                const int glossy = channels >= 2 ? 1 : 0;
                r.bruteMs = b.subsetMs[glossy] * ratio;
                r.bruteWallMs = b.subsetWallMs[glossy] * ratio;
                r.bruteFullMs = b.fullMs[glossy];
                r.bruteFullWallMs = b.fullWallMs[glossy];
                r.bruteCpuMs = b.subsetCpuMs[glossy] * ratio;
                r.bruteFullCpuMs = b.fullCpuMs[glossy];
                const cv::Mat image = readRgb(target.id(), spec.width, spec.height);
                const cv::Mat sampled = subsample(image, spec.subset);
                r.vsSubset = compare(sampled, b.subsetImage[glossy], subset.mask);
                r.meanRatio = totalRatio(sampled, b.subsetImage[glossy], subset.mask);
                if (b.fullMs[glossy]) r.vsFull = compare(image, b.fullImage[glossy], view.mask);
                std::printf("[%5.0f s] %s, %zu sparse, %s: GPU %.1f ms (", msSince(start) / 1000.0,
                            mapName(map).c_str(), r.sparse, channelName(channels), r.gpuMs);
                for (const auto& st : r.stages) std::printf(" %s %.1f", st.first.c_str(), st.second);
                std::printf(" ), wall %.1f ms, process CPU %.1f ms; speed-up %.0fx%s; vs brute (subset) %s\n", r.cpuMs,
                            r.cpuTimeMs, (r.bruteFullWallMs ? *r.bruteFullWallMs : r.bruteWallMs) / r.cpuMs,
                            r.bruteFullMs ? " (wall)" : " (wall, extrapolated)", r.vsSubset->describe().c_str());
                std::fflush(stdout);
                rows.push_back(std::move(r));
            }
        }
        brutes.push_back(std::move(b));
    }
    gl::DebugOutput::throwIfErrors("bench table");
    std::string md = tableMarkdown(spec, rows, brutes, view.covered, subset.covered,
                                   header + "- Load average at end: " + loadAverage() + "; run time " +
                                       std::to_string(long(std::lround(msSince(start) / 1000.0))) + " s\n");
    if (stop()) md += "\n" + interruptedLine("bench") + "\n";
    std::filesystem::create_directories(options.out);
    const std::string file = options.out + "/table.md";
    std::ofstream(file) << md;
    std::printf("\n%s\nwrote %s\n", md.c_str(), file.c_str());
}

/// "WxH,WxH,..." of the command-line option `option` (named in the error on a bad item).
std::vector<std::pair<int, int>> parseSizes(const std::string& text, const char* option) {
    return splitList<std::pair<int, int>>(text, [option](const std::string& item) {
        const auto x = item.find('x');
        if (x == std::string::npos) throw Error(option, std::nullopt, "expected WxH, got '" + item + "'");
        return std::make_pair(parseInt(item.substr(0, x), option), parseInt(item.substr(x + 1), option));
    });
}

int runSweep(const SweepBenchOptions& options) {
    StopCheck stop(options.stopRequested);
    int exitCode = 0;
    const auto start = Clock::now();
    Report report = startReport("bench", options.frames);
    report.truthStride = options.truthStride;
    report.quick = options.quick;
    auto context = gl::createHeadlessContext();
    report.renderer = context->describe();
    std::printf("lightskin bench%s: %s\nrenderer: %s\nload average: %s\n", options.quick ? " --quick" : "",
                report.machine.c_str(), report.renderer.c_str(), report.loadStart.c_str());
    World world(options);
    if (!options.exportBlender.empty()) {
        exportBlender(world, options);
        return 0;
    }
    const auto configs = buildSweep(options);
    std::printf("%zu configurations (one knob at a time around the default), %d frames each after a warm-up\n",
                configs.size(), options.frames);
    std::fflush(stdout);
    for (std::size_t i = 0; i < configs.size() && !stop(); ++i) {
        const Config& c = configs[i];
        std::printf(
            "[%zu/%zu %5.0f s] %s%s%s: sparse %d, stride %d, K_cache %d, %s, %dx%d, sphere %zu tris, adaptive %s\n",
            i + 1, configs.size(), msSince(start) / 1000.0, c.axis.c_str(), c.isDefault ? "" : "=",
            c.isDefault ? "" : c.value.c_str(), c.sparse, c.stride, c.kCache, channelName(c.channels), c.width,
            c.height, c.sphereTriangles, c.adaptive ? "on" : "off");
        std::fflush(stdout);
        RunResult r = runConfig(world, options, c);
        std::printf("    %zu VALs, %zu px: GPU %.1f ms (", r.vals, r.covered, r.gpuMs);
        for (const auto& s : r.stages) std::printf(" %s %.1f", s.first.c_str(), s.second);
        std::printf(" ), CPU %.1f ms, VAL generation %.1f ms", r.cpuMs, r.valsMs);
        if (r.bruteMs) std::printf(", speed-up %.0fx", *r.bruteMs / r.gpuMs);
        if (r.vsBrute) std::printf("\n    vs brute: %s", r.vsBrute->describe().c_str());
        if (r.vsTruth) std::printf("\n    vs truth: %s", r.vsTruth->describe().c_str());
        std::printf("\n");
        std::fflush(stdout);
        report.runs.push_back(std::move(r));
        if (c.isDefault) report.runs.push_back(bruteRow(world, c));
    }
    if (options.temporal && !stop()) {
        std::printf("[temporal %5.0f s]\n", msSince(start) / 1000.0);
        report.temporal = runTemporal(world, options, stop);
    }
    report.interrupted = stop();
    if (options.check && !report.interrupted) { // the checks compare whole series: not those of a stopped run
        // More VALs must bring the light closer to the finest VAL map's: checked on the brute force, which has
        // no approximation besides the VAL map. LightSkin's own error against that map is reported only: its
        // sparse-point approximation (rel. MSE ~6e-4 against the same VALs, varying by ~+-6 % between VAL maps)
        // is larger than what a stride step below 8 changes (the brute force's 2e-4 -> 1e-4 at 320x240), so its
        // sum can rise by a step. Above stride 8 the VAL blocks straddle the room's edges and the brute force's
        // own error stops falling (docs/BENCHMARKS.md, "Speed against accuracy: method", `--quick`).
        report.checks.push_back(monotone(report.runs, "sparse", ErrorSeries::SameVals, options.tolerance));
        report.checks.push_back(monotone(report.runs, "stride", ErrorSeries::Discretisation, options.tolerance));
        report.checks.push_back(monotone(report.runs, "stride", ErrorSeries::FineBrute, options.tolerance));
        report.checks.back().required = false;
        for (const char* axis : {"sparse", "stride"}) {
            report.checks.push_back(monotone(report.runs, axis, ErrorSeries::Truth, options.tolerance));
            report.checks.back().required = false;
        }
    }
    gl::DebugOutput::throwIfErrors("bench");
    report.loadEnd = loadAverage();
    report.seconds = msSince(start) / 1000.0;
    writeOutputs(report, options.out);
    // The docs hold the reference run: a stopped run's rows do not replace it.
    const bool updateDocs = !options.docs.empty() && !report.interrupted;
    if (updateDocs) regenerateDocs(report, options.docs);
    if (!options.docs.empty() && !updateDocs) log::warning(options.docs + " not updated: the run was interrupted");
    std::printf("wrote %s/bench.{csv,json,md}%s%s in %.0f s\n", options.out.c_str(), updateDocs ? " and " : "",
                updateDocs ? options.docs.c_str() : "", report.seconds);
    exitCode = 0;
    for (const auto& c : report.checks) {
        std::printf("%s %s: %s\n",
                    c.passed     ? "PASS"
                    : c.required ? "FAIL"
                                 : "INFO (does not hold, reported only)",
                    c.name.c_str(), c.detail.c_str());
        if (!c.passed && c.required) exitCode = 3;
    }
    if (report.interrupted) printInterrupted("bench");
    return exitCode;
}

} // namespace

int runSweepCommand(const SweepBenchOptions& given) {
    SweepBenchOptions options = given;
    if (!options.fromJson.empty()) {
        const Report report = readReport(options.fromJson);
        writeOutputs(report, options.out);
        if (!options.docs.empty()) regenerateDocs(report, options.docs);
        return 0;
    }
    if (options.table1 || options.kinect) {
        TableSpec spec;
        if (options.table1) {
            spec.sparseTotals = {4096, 16384};
            spec.valMaps = {{166, 124}, {312, 234}, {852, 639}}; // ~16k, ~64k, ~512k valid VALs (measured)
        } else {
            spec.width = 640;
            spec.height = 480;
            spec.sparseTotals = {1024, 4096};
            spec.valMaps = {{160, 120}, {320, 240}, {640, 480}};
        }
        if (!options.tableOutput.empty()) {
            const auto sizes = parseSizes(options.tableOutput, "--table-output");
            if (sizes.size() != 1)
                throw Error("--table-output", std::nullopt, "expected one WxH, got '" + options.tableOutput + "'");
            const auto size = sizes[0];
            spec.width = size.first;
            spec.height = size.second;
        }
        if (!options.tableSparse.empty())
            spec.sparseTotals =
                splitList<int>(options.tableSparse, [](const std::string& v) { return parseInt(v, "--table-sparse"); });
        if (!options.tableVals.empty()) spec.valMaps = parseSizes(options.tableVals, "--table-vals");
        if (options.tableSubset > 0) spec.subset = options.tableSubset;
        spec.frames = options.tableFrames;
        runTable(options, spec, options.table1 ? "The paper's Table 1 setups" : "Kinect setups");
        return 0;
    }
    if (options.quick) {
        applyQuick(options);
        options.out = given.out;
        options.docs = given.docs;
        options.bunnyPath = given.bunnyPath;
        options.temporal = given.temporal;
    }
    return runSweep(options);
}

} // namespace lightskin::bench
