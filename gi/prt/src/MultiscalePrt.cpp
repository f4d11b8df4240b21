// Multi-scale PRT as an IndirectIllumination technique: prepare() loads or computes the transfer, render()
// runs the per-frame CPU part and shades on GL. Design and formulas: gi/prt/include/lightskin/gi/prt/MultiscalePrt.h.
#include "PrtGeometry.h"
#include "PrtSmallScale.h"
#include "common/src/LightsShaders.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/gi/prt/MultiscalePrt.h>
#include <lightskin/gl/ShaderLibrary.h>

#include <epoxy/gl.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/matrix.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <string>
#include <system_error>

namespace lightskin::gi {
namespace {

using Clock = std::chrono::steady_clock;
double millisecondsSince(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

struct Uniforms { // explicit locations (gi/prt/shaders/prt_shade.*)
    static constexpr GLint clipFromWorld = 0, worldFromModel = 1, firstVertex = 2, eye = 3, positionTolerance = 4,
                           smallScaleMode = 5, smallScaleFactor = 6;
};

// GLSL smoothstep, as render/shaders/shade.frag's spot cone.
float smoothStep(float edge0, float edge1, float x) {
    const float t = glm::clamp((x - edge0) / (edge1 - edge0), 0.0f, 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

std::string hex(std::uint64_t value) {
    char text[17];
    std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(value));
    return text;
}

} // namespace

struct MultiscalePrt::Impl {
    MultiscalePrtSettings settings;
    gl::ShaderLibrary library{embeddedShaders()};
    gl::Program shade;
    gl::Framebuffer framebuffer;
    gl::Buffer exitBuffer; // vec4 per exit point
    PrtData data;
    detail::PrtGeometry scene;
    detail::PrtSmallScale smallScale;
    bool prepared = false, fromCache = false;
    std::filesystem::path cacheFile;
    std::vector<PrtLight> lights;
    std::vector<VirtualAreaLight> vals; // read-back, grown only when a frame brings more VALs
    PrtGatherPlan gatherPlan;
    std::vector<glm::vec3> entryIrradiance, exitIrradiance, gathered;
    std::vector<glm::vec4> exitUpload;
    // CPU wall milliseconds of the last render(): read-back, the VALs and the scene lights at the entry points,
    // exit irradiance, shading pass.
    std::vector<gl::StageTime> stageTimes{
        {"read-back", 0.0}, {"entry", 0.0}, {"lights", 0.0}, {"exit", 0.0}, {"shade", 0.0}};
    float epsilon = 1e-6f;
    PrtPrepareStats stats;

    void addLightIrradiance() {
        // A few thousand shadow rays take ~0.1 ms on one core; a parallel region's barrier on the loaded
        // machine waited 10-50 ms in one frame of two (replay of orbit_prt.json, 512 rays), so only many go
        // parallel.
        const bool parallel = data.entryCount() * lights.size() > 16384;
        for (const PrtLight& light : lights) {
            const glm::vec3 intensity = light.power / (4.0f * std::numbers::pi_v<float>); // W/sr
#pragma omp parallel for schedule(static) if (parallel)
            for (std::ptrdiff_t e = 0; e < std::ptrdiff_t(data.entryCount()); ++e) {
                const glm::vec3 p = data.entryPositions[std::size_t(e)], n = data.entryNormals[std::size_t(e)];
                const glm::vec3 d = light.position - p;
                const float d2 = glm::dot(d, d);
                if (!(d2 > 0.0f)) continue;
                const glm::vec3 l = d / std::sqrt(d2);
                const float cosine = glm::dot(n, l);
                if (cosine <= 0.0f) continue;
                float cone = 1.0f;
                if (light.cosOuter > -1.5f)
                    cone = smoothStep(light.cosOuter, light.cosInner, glm::dot(-l, light.direction));
                if (cone <= 0.0f) continue;
                if (scene.occluded(p + epsilon * n, light.position, epsilon)) continue;
                entryIrradiance[std::size_t(e)] += intensity * (cone * cosine / d2);
            }
        }
    }
};

MultiscalePrt::MultiscalePrt()
    : impl_(std::make_unique<Impl>()) {}
MultiscalePrt::~MultiscalePrt() = default;

std::unique_ptr<MultiscalePrt> MultiscalePrt::create(const MultiscalePrtSettings& settings) {
    validate(settings);
    std::unique_ptr<MultiscalePrt> out(new MultiscalePrt());
    Impl& impl = *out->impl_;
    impl.settings = settings;
    impl.shade =
        impl.library.buildProgram({{GL_VERTEX_SHADER, "prt_shade.vert"}, {GL_FRAGMENT_SHADER, "prt_shade.frag"}});
    impl.framebuffer = gl::Framebuffer::create();
    return out;
}

void MultiscalePrt::prepare(std::span<const MeshInstance> instances) {
    Impl& impl = *impl_;
    const auto prepareStart = Clock::now();
    impl.scene = detail::PrtGeometry::create(instances);
    impl.smallScale = detail::PrtSmallScale::create(instances);
    impl.epsilon = std::max(1e-6f, 1e-4f * impl.scene.diagonal);
    const std::uint64_t key = prtCacheKey(instances, impl.settings);
    impl.fromCache = false;
    impl.cacheFile.clear();
    if (!impl.settings.cacheDirectory.empty()) {
        impl.cacheFile = impl.settings.cacheDirectory / ("prt-" + hex(key) + ".bin");
        std::string reason;
        const auto start = Clock::now();
        if (loadPrtCache(impl.cacheFile, key, impl.data, reason)) {
            impl.fromCache = true;
            log::info("multiscale-prt: loaded " + impl.cacheFile.string() + " (" +
                      std::to_string(impl.data.byteSize() >> 10) + " KiB) in " +
                      std::to_string(millisecondsSince(start)) + " ms");
        } else if (reason != "no cache file") {
            log::warning("multiscale-prt: " + impl.cacheFile.string() + ": " + reason + "; recomputing");
        }
    }
    if (!impl.fromCache) {
        impl.data = precomputePrt(instances, impl.settings);
        log::info("multiscale-prt: precomputed " + std::to_string(impl.data.entryCount()) + " entry x " +
                  std::to_string(impl.data.exitCount()) + " exit points, " + std::to_string(impl.data.clusterCount) +
                  " clusters, D = " + std::to_string(impl.data.basisVectors) + " in " +
                  std::to_string(impl.data.precomputeSeconds) + " s, " + std::to_string(impl.data.byteSize() >> 10) +
                  " KiB");
        if (!impl.cacheFile.empty()) {
            try {
                savePrtCache(impl.data, impl.cacheFile);
            } catch (const Error& error) { // a read-only folder costs the next run a precompute, not this one
                log::warning(std::string("multiscale-prt: the cache was not written: ") + error.what());
            }
        }
    }
    impl.entryIrradiance.assign(impl.data.entryCount(), glm::vec3(0.0f));
    impl.exitIrradiance.assign(impl.data.exitCount(), glm::vec3(0.0f));
    impl.exitUpload.assign(impl.data.exitCount(), glm::vec4(0.0f));
    impl.gatherPlan = planPrtGather(impl.data, impl.settings.directGatherPoints, impl.settings.directNeighbours);
    impl.gathered.assign(3 * impl.gatherPlan.points.size(), glm::vec3(0.0f));
    if (!impl.gatherPlan.exact())
        log::info("multiscale-prt: the VALs' first bounce at " + std::to_string(impl.gatherPlan.points.size()) +
                  " of " + std::to_string(impl.data.exitCount()) + " exit points, interpolated to the others");
    impl.exitBuffer =
        gl::Buffer::create(GLsizeiptr(std::max<std::size_t>(1, impl.data.exitCount()) * sizeof(glm::vec4)));
    impl.prepared = true;
    impl.stats = PrtPrepareStats{};
    impl.stats.loadedFromCache = impl.fromCache;
    impl.stats.precomputeSeconds = impl.fromCache ? 0.0 : impl.data.precomputeSeconds;
    impl.stats.memoryBytes = impl.data.byteSize();
    impl.stats.cacheFile = impl.cacheFile;
    std::error_code error; // a cache that could not be written reports 0 bytes (the warning above says why)
    if (!impl.cacheFile.empty()) {
        const std::uintmax_t bytes = std::filesystem::file_size(impl.cacheFile, error);
        impl.stats.cacheFileBytes = error ? 0 : bytes;
    }
    impl.stats.prepareSeconds = millisecondsSince(prepareStart) / 1000.0;
}

void MultiscalePrt::setLights(std::span<const PrtLight> lights) { impl_->lights.assign(lights.begin(), lights.end()); }

void MultiscalePrt::render(const ValSetView& lights, std::span<const MeshInstance> instances,
                           const GBufferView& gbuffer, const ViewParameters& view, std::uint32_t targetTexture) {
    Impl& impl = *impl_;
    LIGHTSKIN_ASSERT(impl.prepared, "lightskin::gi::MultiscalePrt::render(): prepare() first");
    LIGHTSKIN_ASSERT(instances.size() + 1 == impl.data.exitOffsets.size(),
                     "lightskin::gi::MultiscalePrt::render(): the instances are not the prepared ones");
    auto start = Clock::now();
    if (lights.count > impl.vals.size()) {
        // Sized once to the producer's whole buffer (its capacity), so later frames do not reallocate.
        GLint64 bytes = 0;
        glGetNamedBufferParameteri64v(lights.buffer, GL_BUFFER_SIZE, &bytes);
        impl.vals.resize(std::max<std::size_t>(lights.count, std::size_t(bytes) / sizeof(VirtualAreaLight)));
    }
    if (lights.count > 0)
        glGetNamedBufferSubData(lights.buffer, 0, GLsizeiptr(lights.count * sizeof(VirtualAreaLight)),
                                impl.vals.data());
    const std::span<const VirtualAreaLight> vals(impl.vals.data(), lights.count);
    impl.stageTimes[0].milliseconds = millisecondsSince(start);

    start = Clock::now();
    prtEntryIrradianceInto(impl.data, vals, impl.entryIrradiance);
    impl.stageTimes[1].milliseconds = millisecondsSince(start);

    start = Clock::now();
    impl.addLightIrradiance();
    impl.stageTimes[2].milliseconds = millisecondsSince(start);

    start = Clock::now();
    prtExitIrradianceInto(impl.data, impl.gatherPlan, vals, impl.entryIrradiance, impl.gathered, impl.exitIrradiance);
    for (std::size_t x = 0; x < impl.exitIrradiance.size(); ++x)
        impl.exitUpload[x] = glm::vec4(impl.exitIrradiance[x], 0.0f);
    impl.stageTimes[3].milliseconds = millisecondsSince(start);

    start = Clock::now();
    if (!impl.exitUpload.empty())
        glNamedBufferSubData(impl.exitBuffer.id(), 0, GLsizeiptr(impl.exitUpload.size() * sizeof(glm::vec4)),
                             impl.exitUpload.data());
    const float zeros[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    glNamedFramebufferTexture(impl.framebuffer.id(), GL_COLOR_ATTACHMENT0, targetTexture, 0);
    glBindFramebuffer(GL_FRAMEBUFFER, impl.framebuffer.id());
    glClearNamedFramebufferfv(impl.framebuffer.id(), GL_COLOR, 0, zeros);
    glViewport(0, 0, gbuffer.width, gbuffer.height);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_BLEND);
    impl.shade.use();
    const GLuint program = impl.shade.id();
    glProgramUniformMatrix4fv(program, Uniforms::clipFromWorld, 1, GL_FALSE, glm::value_ptr(view.clip_T_world));
    glProgramUniform3fv(program, Uniforms::eye, 1, glm::value_ptr(view.cameraPositionWorld));
    glProgramUniform1f(program, Uniforms::positionTolerance, 1e-4f);
    glBindTextureUnit(0, gbuffer.worldPosition);
    glBindTextureUnit(1, gbuffer.worldNormal);
    glBindTextureUnit(2, gbuffer.diffuseAlbedo);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, impl.exitBuffer.id());
    for (std::size_t m = 0; m < instances.size(); ++m) {
        glProgramUniformMatrix4fv(program, Uniforms::worldFromModel, 1, GL_FALSE,
                                  glm::value_ptr(instances[m].world_T_model));
        glProgramUniform1ui(program, Uniforms::firstVertex, impl.data.exitOffsets[m]);
        const detail::SmallScaleBinding& small = impl.smallScale.binding(m);
        glProgramUniform1i(program, Uniforms::smallScaleMode, int(small.mode));
        glProgramUniform1f(program, Uniforms::smallScaleFactor, small.factor);
        glBindTextureUnit(3, small.texture);
        setFrontFaceFor(instances[m].world_T_model); // prt_shade.frag keeps front-facing fragments only
        glBindVertexArray(instances[m].gpu.vertexArray);
        glDrawElements(GL_TRIANGLES, GLsizei(instances[m].gpu.indexCount), GL_UNSIGNED_INT, nullptr);
    }
    glFrontFace(GL_CCW);
    glBindVertexArray(0);
    glBindTextureUnit(3, 0);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    impl.stageTimes[4].milliseconds = millisecondsSince(start);
}

void MultiscalePrt::lastStageTimes(std::vector<gl::StageTime>& out) const { out = impl_->stageTimes; }
TechniqueCapabilities MultiscalePrt::capabilities() const noexcept {
    static constexpr CpuStageLabel kStages[] = {{"read-back", "gi prt read-back"},
                                                {"entry", "gi prt entry"},
                                                {"lights", "gi prt lights"},
                                                {"exit", "gi prt exit"},
                                                {"shade", "gi prt shade"}};
    return {.glossy = false,
            .occlusion = false,
            .sparsePoints = false,
            .vertexVpls = false,
            .placementInPrepare = true, // the transfer between objects is precomputed for their placement
            .sceneLightsAtCreation = true,
            .cpuStages = kStages};
}
const PrtData& MultiscalePrt::data() const { return impl_->data; }
bool MultiscalePrt::loadedFromCache() const { return impl_->fromCache; }
std::filesystem::path MultiscalePrt::cacheFile() const { return impl_->cacheFile; }
PrtPrepareStats MultiscalePrt::lastPrepareStats() const { return impl_->stats; }
std::span<const glm::vec3> MultiscalePrt::lastExitIrradiance() const { return impl_->exitIrradiance; }
const PrtGatherPlan& MultiscalePrt::gatherPlan() const { return impl_->gatherPlan; }

} // namespace lightskin::gi
