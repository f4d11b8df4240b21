// `lightskin bench-cull`: cost of the adaptive mode's VAL culling (LightSkinSettings::adaptive),
// the stable compaction (count, scan, scatter; the default) against the former atomic append
// (LightSkinSettings::stableCull = false), side by side in one run. A benchmark, not a test:
// results go to docs/BENCHMARKS.md with the command line that produced them.
//
// The cull runs in the technique's "upload" GPU stage, together with the eps_l sums over all VALs
// and the sparse-point upload (the same in every row); adaptive off (a plain VAL copy instead of
// the cull) is shown as the baseline. llvmpipe's timer queries may not cover compute work that
// nothing waits for, so the whole frame's wall-clock time (glFinish before and after) is shown too:
// the two adaptive variants gather the same VALs, their frame-time difference is the cull's. Scene: a 1 m floor grid
// with 16 sparse points (so the gather stays cheap), N random VALs around it: about half face away (culled), 1/17
// invalid.

#include <lightskin/bench/BenchScene.h>
#include <lightskin/bench/CullBench.h>
#include <lightskin/bench/StopRequest.h>
#include <lightskin/core/Error.h>
#include <lightskin/gi/lightskin/LightSkinIllumination.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gi/common/VertexSparsePoints.h>
#include <lightskin/gl/Context.h>
#include <lightskin/gl/DebugOutput.h>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <vector>

namespace lightskin::bench {

namespace {

TriangleMesh floorGrid(int cells) {
    TriangleMesh mesh;
    for (int i = 0; i <= cells; ++i)
        for (int j = 0; j <= cells; ++j) {
            mesh.positions.emplace_back(float(j) / float(cells) - 0.5f, float(i) / float(cells) - 0.5f, 0.0f);
            mesh.normals.emplace_back(0.0f, 0.0f, 1.0f);
        }
    for (int i = 0; i < cells; ++i)
        for (int j = 0; j < cells; ++j) {
            const auto a = std::uint32_t(i * (cells + 1) + j), b = a + std::uint32_t(cells + 1);
            mesh.indices.insert(mesh.indices.end(), {a, a + 1, b + 1, a, b + 1, b});
        }
    return mesh;
}

std::vector<gi::VirtualAreaLight> randomVals(std::uint32_t count) {
    std::mt19937 rng(count);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<gi::VirtualAreaLight> vals(count);
    for (std::uint32_t i = 0; i < count; ++i) {
        gi::VirtualAreaLight& v = vals[i];
        v.position = glm::vec3(-2.0f, -2.0f, -1.0f) + glm::vec3(4.0f, 4.0f, 3.0f) * glm::vec3(u(rng), u(rng), u(rng));
        const float z = 2.0f * u(rng) - 1.0f, phi = 2.0f * std::numbers::pi_v<float> * u(rng);
        const float s = std::sqrt(std::max(1.0f - z * z, 0.0f));
        v.normal = {s * std::cos(phi), s * std::sin(phi), z};
        v.area = i % 17 == 5 ? std::numeric_limits<float>::quiet_NaN() : 1e-3f + 1e-2f * u(rng);
        v.flux = glm::vec3(u(rng), u(rng), u(rng)) * 0.2f;
    }
    return vals;
}

double stage(const std::vector<gl::StageTime>& stages, const char* name) {
    for (const gl::StageTime& t : stages)
        if (t.name == name) return t.milliseconds;
    return 0.0;
}

} // namespace

void runCullBench(const CullBenchOptions& options) {
    StopCheck stop(options.stopRequested);
    auto context = gl::createHeadlessContext();
    std::printf("renderer: %s\n", context->describe().c_str());
    TriangleMesh mesh = floorGrid(16);
    const gi::UploadedMesh gpu = gi::UploadedMesh::create(mesh);
    std::vector<gi::MeshInstance> instances(1);
    instances[0].mesh = &mesh;
    instances[0].gpu = gpu.view();
    const int width = 64, height = 64;
    const glm::vec3 eye(1.2f, -1.4f, 1.2f);
    const gi::ViewParameters view{
        glm::perspective(0.8f, 1.0f, 0.05f, 50.0f) * glm::lookAt(eye, glm::vec3(0.0f), glm::vec3(0, 0, 1)), eye};
    gi::SimpleGBuffer gbuffer = gi::SimpleGBuffer::create(width, height);
    gbuffer.render(instances, view.clip_T_world);
    gl::Texture target = gl::Texture::create2D(GL_RGBA32F, width, height);
    const auto provider = [](const gi::MeshInstance& instance) {
        return gi::sparsePointsFromVertices(*instance.mesh, 16);
    };

    struct Variant {
        const char* name;
        bool adaptive, stable;
    };
    const Variant variants[] = {{"adaptive off (VAL copy)", false, true},
                                {"atomic append (before)", true, false},
                                {"stable compaction (after)", true, true}};
    std::printf("upload stage (GPU timer) / whole frame (wall clock, glFinish), minimum over %d frames\n",
                options.repeat);
    std::printf("| VALs | kept | %s | %s | %s |\n|---|---|---|---|---|\n", variants[0].name, variants[1].name,
                variants[2].name);
    std::fflush(stdout);
    for (const std::uint32_t count : options.counts) {
        if (stop()) break;
        const auto vals = randomVals(count);
        const gl::Buffer buffer =
            gl::Buffer::create(GLsizeiptr(std::max<std::size_t>(vals.size(), 1) * sizeof(gi::VirtualAreaLight)),
                               vals.empty() ? nullptr : vals.data(), 0);
        double best[3] = {1e30, 1e30, 1e30}, wall[3] = {1e30, 1e30, 1e30};
        std::uint32_t kept = 0;
        std::vector<std::unique_ptr<gi::LightSkinIllumination>> techniques;
        for (const Variant& v : variants) {
            gi::LightSkinSettings settings;
            settings.adaptive = v.adaptive;
            settings.stableCull = v.stable;
            settings.reuseStatic = false;
            settings.glossy = false;
            settings.occlusion = false;
            settings.valCapacity = std::max(count, 1u);
            techniques.push_back(gi::LightSkinIllumination::create(settings, provider));
            techniques.back()->prepare(instances);
        }
        std::vector<gl::StageTime> stages;
        for (int r = 0; r < options.repeat && !stop(); ++r)
            for (std::size_t k = 0; k < techniques.size(); ++k) { // interleaved: load changes hit all variants
                glFinish();
                const auto start = std::chrono::steady_clock::now();
                techniques[k]->render({buffer.id(), count}, instances, gbuffer.view(), view, target.id());
                glFinish();
                wall[k] = std::min(
                    wall[k],
                    std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
                techniques[k]->lastStageTimes(stages);
                best[k] = std::min(best[k], stage(stages, "upload"));
                if (k == 2) kept = techniques[k]->lastChoice().valsGathered;
            }
        if (stop.stopped()) break; // a row cut short is not shown: its minimum would be over fewer frames
        std::printf("| %u | %u | %.2f / %.1f ms | %.2f / %.1f ms | %.2f / %.1f ms |\n", count, kept, best[0], wall[0],
                    best[1], wall[1], best[2], wall[2]);
        std::fflush(stdout);
    }
    gl::DebugOutput::throwIfErrors("bench-cull");
    if (stop()) printInterrupted("bench-cull");
}

} // namespace lightskin::bench
