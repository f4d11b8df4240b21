#include "common/src/LightsShaders.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/gi/volumes/ImperfectVolumes.h>
#include <lightskin/gl/ShaderLibrary.h>

#include <epoxy/gl.h>
#include <glm/common.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <unordered_map>

namespace lightskin::gi {
namespace {

constexpr int kMaxResolution = 256;
constexpr GLuint kMaxGroups = 65535; // per dispatch dimension (GL 4.5 minimum)
// Loop iterations per shader invocation that llvmpipe completes (it ends a loop after ~65,000).
constexpr long kLoopBudget = 60000;

void checkRange(const char* field, long value, long lo, long hi) {
    if (value < lo || value > hi)
        throw Error("gi.imperfectVolumes", std::nullopt,
                    std::string(field) + " = " + std::to_string(value) + " is outside [" + std::to_string(lo) + ", " +
                        std::to_string(hi) + "]");
}

void checkPositive(const char* field, float value, bool zeroAllowed) {
    if (!std::isfinite(value) || value < 0.0f || (!zeroAllowed && value == 0.0f))
        throw Error("gi.imperfectVolumes", std::nullopt,
                    std::string(field) + " = " + std::to_string(value) + " must be a finite number " +
                        (zeroAllowed ? ">= 0" : "> 0"));
}

// Equal-area stratification as lightskin::gi::reference::volumes::stratifiedDirections: round(sqrt N)
// bands in z, cells evenly spaced in phi, each direction at its cell's centre.
std::vector<glm::vec4> stratifiedDirections(int count) {
    std::vector<glm::vec4> out;
    out.reserve(std::size_t(count));
    const int bands = std::max(1, int(std::lround(std::sqrt(double(count)))));
    for (int b = 0; b < bands; ++b) {
        const long begin = (long(count) * b) / bands, end = (long(count) * (b + 1)) / bands;
        const double z = -1.0 + double(begin + end) / double(count);
        const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
        for (long c = 0; c < end - begin; ++c) {
            const double phi = 2.0 * std::numbers::pi * (double(c) + 0.5) / double(end - begin);
            out.emplace_back(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z), 0.0f);
        }
    }
    return out;
}

// A per-voxel (or per-slot) pass over `items` invocations in groups of 64, split into rows of at
// most kMaxGroups groups (the shaders' linearIndex()): 256^3 needs 262144 groups.
void dispatchLinear(std::uint32_t items) {
    const GLuint groups = std::max<GLuint>(1u, (items + 63u) / 64u);
    const GLuint x = std::min(groups, kMaxGroups);
    glDispatchCompute(x, (groups + x - 1u) / x, 1);
}

// PCG output hash (as the shaders' pcgHash): per-frame jitter values.
std::uint32_t pcgHash(std::uint32_t value) {
    const std::uint32_t state = value * 747796405u + 2891336453u;
    const std::uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

struct MeshBuffers {
    gl::Buffer positions, normals, indices;
    std::uint32_t triangles = 0;
    glm::vec3 boundsMin{0.0f}, boundsMax{0.0f}; // model space
};

struct Uniforms { // explicit locations (gi/volumes/shaders/volumes_*.comp)
    static constexpr GLint origin = 0, voxelSize = 1, resolution = 2, first = 3;
    // volumes_inject_mesh.comp's lights (arrays of kMaxVolumeLights locations each)
    static constexpr GLint lightCount = 9, lightPosition = 10, lightDirection = 14, lightIntensity = 18, lightCos = 22,
                           lightShadows = 26;
};

} // namespace

void validate(const ImperfectVolumesSettings& s) {
    checkRange("resolution", s.resolution, 1, kMaxResolution);
    checkRange("pointsPerTriangle", s.pointsPerTriangle, 0, 256);
    checkRange("raysPerVoxel", s.raysPerVoxel, 1, 4096);
    checkRange("bounces", s.bounces, 1, 4);
    checkPositive("aoRange", s.aoRange, false);
    checkPositive("margin", s.margin, true);
    checkPositive("size", s.size, false);
    checkPositive("realAlbedo", s.realAlbedo, true);
    if (s.realAlbedo > 1.0f) throw Error("gi.imperfectVolumes", std::nullopt, "realAlbedo must be <= 1");
    if (!std::isfinite(s.temporalBlend) || s.temporalBlend < 0.0f || s.temporalBlend > 0.95f)
        throw Error("gi.imperfectVolumes", std::nullopt,
                    "temporalBlend = " + std::to_string(s.temporalBlend) + " is outside [0, 0.95]");
    if (!std::isfinite(s.origin.x) || !std::isfinite(s.origin.y) || !std::isfinite(s.origin.z))
        throw Error("gi.imperfectVolumes", std::nullopt, "origin must be finite");
}

struct ImperfectVolumes::Impl {
    ImperfectVolumesSettings settings;
    gl::ShaderLibrary library{embeddedShaders()};
    gl::Program flagMesh, flagVals, allocateOccupied, allocateActive;
    gl::Program injectMesh, injectVals, resolve, markPixels, markVoxels, gather, bounce, reconstruct;
    // Sparse storage (volumes_common.glsl): dense slot maps, compact arrays of `capacity` slots.
    gl::Buffer occupiedSlot, activeSlot, counters;
    gl::Buffer accumulation, voxels, exitant, incoming, directions;
    gl::Buffer history, historySlot; // temporalBlend: the previous frame's SH and its slot map
    std::uint32_t capacity = 0;
    glm::uvec2 dropped{0u};      // of the last render(): requested slots beyond capacity
    bool overflowWarned = false; // one warning per technique object, not per frame
    bool historyValid = false;
    std::uint32_t frame = 0;
    std::unordered_map<std::uint32_t, MeshBuffers> meshes;
    gl::GpuStageTimer timer;
    std::vector<gl::StageTime> stageTimes;
    glm::vec3 origin{0.0f};
    float voxelSize = 1.0f;
    std::uint32_t voxelCount = 0;
    std::vector<VolumeLight> lights; // setDirectLights(): at most kMaxVolumeLights
    std::uint32_t shadowDistanceCubes = 0;

    void setGrid(const gl::Program& program) const {
        glProgramUniform3fv(program.id(), Uniforms::origin, 1, glm::value_ptr(origin));
        glProgramUniform1f(program.id(), Uniforms::voxelSize, voxelSize);
        glProgramUniform1i(program.id(), Uniforms::resolution, settings.resolution);
    }
    void fitGrid(std::span<const MeshInstance> instances);
    void injectPoints(std::span<const MeshInstance> instances, const ValSetView& vals, bool flag,
                      std::uint32_t frameHash) const;
    // Slots for the flagged voxels of the map bound at 5 (counter 0: occupied, 1: ray-marched).
    void allocate(const gl::Program& program, GLuint counter) const {
        program.use();
        setGrid(program);
        glUniform1ui(Uniforms::first, capacity);
        glUniform1ui(Uniforms::first + 1, counter);
        dispatchLinear(voxelCount);
    }

    // Uniforms 9-29 of volumes_inject_mesh.comp (its program in use) and the shadow cube maps.
    void setLights() const {
        glm::vec3 position[kMaxVolumeLights]{}, direction[kMaxVolumeLights]{}, intensity[kMaxVolumeLights]{};
        glm::vec2 cosines[kMaxVolumeLights]{};
        GLint shadows[kMaxVolumeLights]{};
        for (std::size_t i = 0; i < lights.size(); ++i) {
            position[i] = lights[i].position;
            direction[i] = lights[i].direction;
            intensity[i] = lights[i].intensity;
            cosines[i] = {lights[i].cosOuter, lights[i].cosInner};
            shadows[i] = lights[i].castsShadows && shadowDistanceCubes != 0 ? 1 : 0;
        }
        glUniform1i(Uniforms::lightCount, GLint(lights.size()));
        glUniform3fv(Uniforms::lightPosition, kMaxVolumeLights, glm::value_ptr(position[0]));
        glUniform3fv(Uniforms::lightDirection, kMaxVolumeLights, glm::value_ptr(direction[0]));
        glUniform3fv(Uniforms::lightIntensity, kMaxVolumeLights, glm::value_ptr(intensity[0]));
        glUniform2fv(Uniforms::lightCos, kMaxVolumeLights, glm::value_ptr(cosines[0]));
        glUniform1iv(Uniforms::lightShadows, kMaxVolumeLights, shadows);
        if (shadowDistanceCubes != 0) glBindTextureUnit(0, shadowDistanceCubes);
    }
};

ImperfectVolumes::ImperfectVolumes()
    : impl_(std::make_unique<Impl>()) {}
ImperfectVolumes::~ImperfectVolumes() = default;

std::unique_ptr<ImperfectVolumes> ImperfectVolumes::create(const ImperfectVolumesSettings& settings) {
    validate(settings);
    std::unique_ptr<ImperfectVolumes> technique(new ImperfectVolumes());
    Impl& impl = *technique->impl_;
    impl.settings = settings;
    const std::vector<std::string> visibility =
        settings.ambientOcclusion ? std::vector<std::string>{"VOLUMES_VISIBILITY"} : std::vector<std::string>{};
    const std::vector<std::string> flag{"VOLUMES_MARK_OCCUPANCY"};
    impl.flagMesh = impl.library.buildProgram({{GL_COMPUTE_SHADER, "volumes_inject_mesh.comp"}}, flag);
    impl.flagVals = impl.library.buildProgram({{GL_COMPUTE_SHADER, "volumes_inject_vals.comp"}}, flag);
    const std::vector<std::string> clearSums{"VOLUMES_CLEAR_ACCUMULATION"};
    impl.allocateOccupied = impl.library.buildProgram({{GL_COMPUTE_SHADER, "volumes_allocate.comp"}}, clearSums);
    impl.allocateActive = impl.library.buildProgram({{GL_COMPUTE_SHADER, "volumes_allocate.comp"}});
    impl.injectMesh = impl.library.buildProgram({{GL_COMPUTE_SHADER, "volumes_inject_mesh.comp"}});
    impl.injectVals = impl.library.buildProgram({{GL_COMPUTE_SHADER, "volumes_inject_vals.comp"}});
    impl.resolve = impl.library.buildProgram({{GL_COMPUTE_SHADER, "volumes_resolve.comp"}});
    const std::vector<std::string> pixels{"VOLUMES_MARK_PIXELS"};
    impl.markPixels = impl.library.buildProgram({{GL_COMPUTE_SHADER, "volumes_mark.comp"}}, pixels);
    impl.markVoxels = impl.library.buildProgram({{GL_COMPUTE_SHADER, "volumes_mark.comp"}});
    impl.gather = impl.library.buildProgram({{GL_COMPUTE_SHADER, "volumes_gather.comp"}}, visibility);
    impl.bounce = impl.library.buildProgram({{GL_COMPUTE_SHADER, "volumes_bounce.comp"}});
    impl.reconstruct = impl.library.buildProgram({{GL_COMPUTE_SHADER, "volumes_reconstruct.comp"}}, visibility);

    const auto n = GLsizeiptr(settings.resolution);
    impl.voxelCount = std::uint32_t(n * n * n);
    // Compact arrays: one slot per occupied (and per ray-marched) voxel, at most as many as one
    // buffer binding holds (GL_MAX_SHADER_STORAGE_BLOCK_SIZE; 128 MiB on llvmpipe: 2.8 M slots of
    // 48 bytes). Up to 128^3 that is every voxel; at 256^3 the surfaces must fit (counted per frame).
    GLint64 maxBlock = 0;
    glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &maxBlock);
    const GLsizeiptr slotBytes = 12 * GLsizeiptr(sizeof(std::uint32_t)); // the largest: accumulation, SH
    if (GLsizeiptr(impl.voxelCount) * GLsizeiptr(sizeof(std::uint32_t)) > maxBlock)
        throw Error("gi.imperfectVolumes", std::nullopt,
                    "resolution = " + std::to_string(settings.resolution) + ": the slot map needs " +
                        std::to_string(impl.voxelCount * 4ull) + " bytes, more than one storage buffer holds here (" +
                        std::to_string(maxBlock) + ")");
    impl.capacity = std::uint32_t(std::min<GLint64>(GLint64(impl.voxelCount), maxBlock / slotBytes));
    if (settings.maxSlots > 0) impl.capacity = std::min(impl.capacity, settings.maxSlots);
    const GLsizeiptr voxels = GLsizeiptr(impl.voxelCount), slots = GLsizeiptr(impl.capacity);
    impl.occupiedSlot = gl::Buffer::create(voxels * GLsizeiptr(sizeof(std::uint32_t)));
    impl.activeSlot = gl::Buffer::create(voxels * GLsizeiptr(sizeof(std::uint32_t)));
    impl.counters = gl::Buffer::create(2 * GLsizeiptr(sizeof(std::uint32_t)));
    impl.accumulation = gl::Buffer::create(slots * slotBytes);
    impl.voxels = gl::Buffer::create(slots * 3 * GLsizeiptr(sizeof(glm::vec4)));
    impl.exitant = gl::Buffer::create(slots * GLsizeiptr(sizeof(glm::vec4)));
    impl.incoming = gl::Buffer::create(slots * 3 * GLsizeiptr(sizeof(glm::vec4)));
    const bool blend = settings.temporalBlend > 0.0f;
    impl.history = gl::Buffer::create((blend ? slots : 1) * 3 * GLsizeiptr(sizeof(glm::vec4)));
    impl.historySlot = gl::Buffer::create((blend ? voxels : 1) * GLsizeiptr(sizeof(std::uint32_t)));
    const std::vector<glm::vec4> dirs = stratifiedDirections(settings.raysPerVoxel);
    impl.directions = gl::Buffer::create(GLsizeiptr(dirs.size() * sizeof(glm::vec4)), dirs.data());
    impl.timer = gl::GpuStageTimer::create(4);
    return technique;
}

void ImperfectVolumes::prepare(std::span<const MeshInstance> instances) {
    Impl& impl = *impl_;
    impl.meshes.clear();
    std::vector<glm::vec4> positions, normals; // load time: allocation is fine here
    for (const MeshInstance& instance : instances) {
        if (impl.meshes.contains(instance.meshId)) continue;
        if (!instance.mesh) throw Error("imperfect volumes", std::nullopt, "mesh instance without a CPU mesh");
        const TriangleMesh& mesh = *instance.mesh;
        if (mesh.normals.size() != mesh.positions.size() || mesh.indices.size() % 3 != 0)
            throw Error("imperfect volumes", std::nullopt,
                        "mesh " + std::to_string(instance.meshId) + ": normals or indices do not match its positions");
        MeshBuffers buffers;
        buffers.triangles = std::uint32_t(mesh.indices.size() / 3);
        positions.assign(mesh.positions.size(), glm::vec4(0.0f));
        normals.assign(mesh.normals.size(), glm::vec4(0.0f));
        buffers.boundsMin = glm::vec3(std::numeric_limits<float>::max());
        buffers.boundsMax = glm::vec3(std::numeric_limits<float>::lowest());
        for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
            positions[i] = glm::vec4(mesh.positions[i], 1.0f);
            normals[i] = glm::vec4(mesh.normals[i], 0.0f);
            buffers.boundsMin = glm::min(buffers.boundsMin, mesh.positions[i]);
            buffers.boundsMax = glm::max(buffers.boundsMax, mesh.positions[i]);
        }
        for (std::uint32_t index : mesh.indices)
            if (index >= mesh.positions.size())
                throw Error("imperfect volumes", std::nullopt,
                            "mesh " + std::to_string(instance.meshId) + ": index " + std::to_string(index) +
                                " >= vertex count " + std::to_string(mesh.positions.size()));
        if (buffers.triangles == 0) {
            impl.meshes.emplace(instance.meshId, std::move(buffers));
            continue;
        }
        buffers.positions = gl::Buffer::create(GLsizeiptr(positions.size() * sizeof(glm::vec4)), positions.data());
        buffers.normals = gl::Buffer::create(GLsizeiptr(normals.size() * sizeof(glm::vec4)), normals.data());
        buffers.indices =
            gl::Buffer::create(GLsizeiptr(mesh.indices.size() * sizeof(std::uint32_t)), mesh.indices.data());
        impl.meshes.emplace(instance.meshId, std::move(buffers));
    }
}

void ImperfectVolumes::Impl::injectPoints(std::span<const MeshInstance> instances, const ValSetView& valSet, bool flag,
                                          std::uint32_t frameHash) const {
    if (settings.pointsPerTriangle > 0) {
        const gl::Program& mesh = flag ? flagMesh : injectMesh;
        mesh.use();
        setGrid(mesh);
        glUniform1ui(Uniforms::first + 1, std::uint32_t(settings.pointsPerTriangle));
        glUniform1ui(Uniforms::first + 2, settings.seed ^ frameHash);
        for (const MeshInstance& instance : instances) {
            const auto it = meshes.find(instance.meshId);
            LIGHTSKIN_ASSERT(it != meshes.end(),
                             "lightskin::gi::ImperfectVolumes::render(): an instance's mesh was not prepared");
            const MeshBuffers& buffers = it->second;
            if (buffers.triangles == 0) continue;
            const std::uint32_t points = buffers.triangles * std::uint32_t(settings.pointsPerTriangle);
            glUniform1ui(Uniforms::first, points);
            glUniformMatrix4fv(Uniforms::first + 3, 1, GL_FALSE, glm::value_ptr(instance.world_T_model));
            glUniform3fv(Uniforms::first + 4, 1, glm::value_ptr(instance.material.diffuseAlbedo));
            if (!flag) setLights();
            glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 6, buffers.positions.id());
            glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 7, buffers.normals.id());
            glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 8, buffers.indices.id());
            for (std::uint32_t offset = 0; offset < points; offset += kMaxGroups * 64u) {
                glUniform1ui(Uniforms::first + 5, offset);
                glDispatchCompute(std::min(kMaxGroups, (points - offset + 63u) / 64u), 1, 1);
            }
        }
    }
    if (valSet.count > 0) {
        const gl::Program& program = flag ? flagVals : injectVals;
        program.use();
        setGrid(program);
        glUniform1ui(Uniforms::first, valSet.count);
        glUniform3fv(Uniforms::first + 1, 1, glm::value_ptr(glm::vec3(settings.realAlbedo)));
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 6, valSet.buffer);
        for (std::uint32_t offset = 0; offset < valSet.count; offset += kMaxGroups * 64u) {
            glBindBufferRange(GL_SHADER_STORAGE_BUFFER, 6, valSet.buffer, GLintptr(offset) * 48,
                              GLsizeiptr(std::min(valSet.count - offset, kMaxGroups * 64u)) * 48);
            glUniform1ui(Uniforms::first, std::min(valSet.count - offset, kMaxGroups * 64u));
            glDispatchCompute(std::min(kMaxGroups, (valSet.count - offset + 63u) / 64u), 1, 1);
        }
    }
}

void ImperfectVolumes::Impl::fitGrid(std::span<const MeshInstance> instances) {
    if (!settings.autoFit) {
        origin = settings.origin;
        voxelSize = settings.size / float(settings.resolution);
        return;
    }
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(std::numeric_limits<float>::lowest());
    for (const MeshInstance& instance : instances) {
        const auto it = meshes.find(instance.meshId);
        if (it == meshes.end() || it->second.triangles == 0) continue;
        for (int corner = 0; corner < 8; ++corner) {
            const glm::vec3 c((corner & 1) ? it->second.boundsMax.x : it->second.boundsMin.x,
                              (corner & 2) ? it->second.boundsMax.y : it->second.boundsMin.y,
                              (corner & 4) ? it->second.boundsMax.z : it->second.boundsMin.z);
            const glm::vec3 w(instance.world_T_model * glm::vec4(c, 1.0f));
            lo = glm::min(lo, w);
            hi = glm::max(hi, w);
        }
    }
    if (lo.x > hi.x) { // no virtual triangles: the fixed grid
        origin = settings.origin;
        voxelSize = settings.size / float(settings.resolution);
        return;
    }
    lo -= glm::vec3(settings.margin);
    hi += glm::vec3(settings.margin);
    const float side = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 1e-3f});
    origin = 0.5f * (lo + hi) - glm::vec3(0.5f * side);
    voxelSize = side / float(settings.resolution);
}

void ImperfectVolumes::render(const ValSetView& lights, std::span<const MeshInstance> instances,
                              const GBufferView& gbuffer, const ViewParameters&, std::uint32_t targetTexture) {
    Impl& impl = *impl_;
    const ImperfectVolumesSettings& s = impl.settings;
    const glm::vec3 previousOrigin = impl.origin;
    const float previousVoxelSize = impl.voxelSize;
    impl.fitGrid(instances);
    // History is only meaningful on the same grid.
    const bool blend = s.temporalBlend > 0.0f && impl.historyValid && previousOrigin == impl.origin &&
                       previousVoxelSize == impl.voxelSize;
    // Jitter: a sub-voxel ray origin and fresh triangle points per frame (hash of the frame number).
    ++impl.frame;
    const std::uint32_t frameHash = s.jitter ? pcgHash(impl.frame) : 0u;
    const glm::vec3 originOffset =
        s.jitter ? glm::vec3(float(pcgHash(frameHash ^ 1u) >> 8u), float(pcgHash(frameHash ^ 2u) >> 8u),
                             float(pcgHash(frameHash ^ 3u) >> 8u)) /
                           16777216.0f -
                       0.5f
                 : glm::vec3(0.0f);
    const GLuint pixelGroupsX = GLuint(gbuffer.width + 7) / 8u, pixelGroupsY = GLuint(gbuffer.height + 7) / 8u;
    const std::uint32_t zero = 0;

    impl.timer.beginFrame();
    impl.timer.begin("inject");
    glClearNamedBufferData(impl.occupiedSlot.id(), GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, &zero);
    glClearNamedBufferData(impl.activeSlot.id(), GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, &zero);
    glClearNamedBufferData(impl.counters.id(), GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, &zero);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, impl.accumulation.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 11, impl.occupiedSlot.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 12, impl.counters.id());
    // Two passes over the same points: flag their voxels, give each flagged voxel a slot (its sums
    // zeroed), then add the points to their slots.
    impl.injectPoints(instances, lights, true, frameHash);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5, impl.occupiedSlot.id());
    impl.allocate(impl.allocateOccupied, 0);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    impl.injectPoints(instances, lights, false, frameHash);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    impl.resolve.use();
    glProgramUniform1i(impl.resolve.id(), Uniforms::resolution, s.resolution);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, impl.voxels.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, impl.exitant.id());
    dispatchLinear(impl.voxelCount);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    impl.timer.end();

    impl.timer.begin("ray march");
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5, impl.activeSlot.id());
    impl.markPixels.use();
    impl.setGrid(impl.markPixels);
    glUniform2i(Uniforms::first, gbuffer.width, gbuffer.height);
    glBindTextureUnit(0, gbuffer.worldPosition);
    glBindTextureUnit(1, gbuffer.worldNormal);
    glDispatchCompute(pixelGroupsX, pixelGroupsY, 1);
    const int passes = s.ambientOcclusion ? 1 : s.bounces;
    if (passes > 1) {
        impl.markVoxels.use();
        impl.setGrid(impl.markVoxels);
        dispatchLinear(impl.voxelCount);
    }
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    impl.allocate(impl.allocateActive, 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, impl.incoming.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, impl.directions.id());
    // Steps to cross the grid from inside: at most sqrt(3) n + 1; rays per pass keep rays x steps
    // under llvmpipe's loop budget.
    const int maxSteps = int(std::ceil(std::sqrt(3.0) * s.resolution)) + 2;
    const std::uint32_t raysPerPass = std::uint32_t(std::max<long>(1, kLoopBudget / maxSteps));
    const float maxDistance = s.ambientOcclusion ? s.aoRange : std::numeric_limits<float>::max();
    for (int pass = 0; pass < passes; ++pass) {
        if (pass > 0) {
            impl.bounce.use();
            impl.setGrid(impl.bounce);
            dispatchLinear(impl.voxelCount);
            glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
        }
        impl.gather.use();
        impl.setGrid(impl.gather);
        glUniform1ui(Uniforms::first + 2, std::uint32_t(s.raysPerVoxel));
        glUniform1i(Uniforms::first + 3, maxSteps);
        glUniform1f(Uniforms::first + 4, maxDistance);
        glUniform3fv(Uniforms::first + 5, 1, glm::value_ptr(originOffset));
        glUniform1f(Uniforms::first + 6, blend && pass == passes - 1 ? s.temporalBlend : 0.0f);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 9, impl.history.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 10, impl.historySlot.id());
        for (std::uint32_t begin = 0; begin < std::uint32_t(s.raysPerVoxel); begin += raysPerPass) {
            glUniform1ui(Uniforms::first, begin);
            glUniform1ui(Uniforms::first + 1, std::min(begin + raysPerPass, std::uint32_t(s.raysPerVoxel)));
            dispatchLinear(impl.voxelCount);
            glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
        }
    }
    impl.timer.end();

    if (s.temporalBlend > 0.0f) {
        glCopyNamedBufferSubData(impl.incoming.id(), impl.history.id(), 0, 0,
                                 GLsizeiptr(impl.capacity) * 3 * GLsizeiptr(sizeof(glm::vec4)));
        glCopyNamedBufferSubData(impl.activeSlot.id(), impl.historySlot.id(), 0, 0,
                                 GLsizeiptr(impl.voxelCount) * GLsizeiptr(sizeof(std::uint32_t)));
        impl.historyValid = true;
    }
    impl.timer.begin("reconstruct");
    impl.reconstruct.use();
    impl.setGrid(impl.reconstruct);
    glUniform2i(Uniforms::first, gbuffer.width, gbuffer.height);
    glBindTextureUnit(2, gbuffer.diffuseAlbedo);
    glBindImageTexture(0, targetTexture, 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA32F);
    glDispatchCompute(pixelGroupsX, pixelGroupsY, 1);
    glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT |
                    GL_TEXTURE_UPDATE_BARRIER_BIT);
    glBindImageTexture(0, 0, 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA32F);
    impl.timer.end();
    impl.timer.collect(impl.stageTimes);

    // Only a grid with more voxels than slots (256^3, or a maxSlots cap) can drop voxels: read the
    // two counters back then, so smaller grids keep the frame free of this sync.
    if (impl.capacity < impl.voxelCount) {
        glm::uvec2 requested(0u);
        glGetNamedBufferSubData(impl.counters.id(), 0, GLsizeiptr(sizeof(requested)), &requested);
        impl.dropped = glm::uvec2(requested.x > impl.capacity ? requested.x - impl.capacity : 0u,
                                  requested.y > impl.capacity ? requested.y - impl.capacity : 0u);
        if ((impl.dropped.x > 0u || impl.dropped.y > 0u) && !impl.overflowWarned) {
            impl.overflowWarned = true;
            log::warning("imperfect volumes: " + std::to_string(s.resolution) +
                         "^3 grid: " + std::to_string(impl.dropped.x) + " of " + std::to_string(requested.x) +
                         " occupied and " + std::to_string(impl.dropped.y) + " of " + std::to_string(requested.y) +
                         " ray-marched voxels dropped (" + std::to_string(impl.capacity) +
                         " slots); their light is missing: use a smaller gi.imperfectVolumes resolution "
                         "(this warning is given once)");
        }
    }
}

void ImperfectVolumes::setDirectLights(std::span<const VolumeLight> lights, std::uint32_t shadowDistanceCubes) {
    if (lights.size() > std::size_t(kMaxVolumeLights))
        throw Error("imperfect volumes", std::nullopt,
                    std::to_string(lights.size()) + " lights: at most " + std::to_string(kMaxVolumeLights) +
                        " carry direct light into the volume");
    impl_->lights.assign(lights.begin(), lights.end());
    impl_->shadowDistanceCubes = shadowDistanceCubes;
}

void ImperfectVolumes::lastStageTimes(std::vector<gl::StageTime>& out) const { out = impl_->stageTimes; }

glm::vec3 ImperfectVolumes::gridOrigin() const { return impl_->origin; }
float ImperfectVolumes::voxelSize() const { return impl_->voxelSize; }

namespace {
// Dense per-voxel copy of a compact array of `perSlot` vec4 (element `element` of each) through a slot map.
std::vector<glm::vec4> expandSlots(const gl::Buffer& map, const gl::Buffer& compact, std::uint32_t voxelCount,
                                   std::uint32_t capacity, std::size_t perSlot, std::size_t element) {
    std::vector<std::uint32_t> slots(voxelCount);
    glGetNamedBufferSubData(map.id(), 0, GLsizeiptr(slots.size() * sizeof(std::uint32_t)), slots.data());
    std::vector<glm::vec4> all(std::size_t(capacity) * perSlot);
    glGetNamedBufferSubData(compact.id(), 0, GLsizeiptr(all.size() * sizeof(glm::vec4)), all.data());
    std::vector<glm::vec4> out(std::size_t(voxelCount) * (element == perSlot ? perSlot : 1), glm::vec4(0.0f));
    for (std::size_t i = 0; i < slots.size(); ++i) {
        if (slots[i] == 0) continue;
        const std::size_t slot = slots[i] - 1u;
        if (element == perSlot)
            for (std::size_t k = 0; k < perSlot; ++k) out[i * perSlot + k] = all[slot * perSlot + k];
        else
            out[i] = all[slot * perSlot + element];
    }
    return out;
}
} // namespace

std::vector<glm::vec4> ImperfectVolumes::downloadVoxelNormals() const {
    return expandSlots(impl_->occupiedSlot, impl_->voxels, impl_->voxelCount, impl_->capacity, 3, 0);
}

std::vector<glm::vec4> ImperfectVolumes::downloadVoxelDirect() const {
    return expandSlots(impl_->occupiedSlot, impl_->voxels, impl_->voxelCount, impl_->capacity, 3, 1);
}

std::vector<glm::vec4> ImperfectVolumes::downloadIncoming() const {
    return expandSlots(impl_->activeSlot, impl_->incoming, impl_->voxelCount, impl_->capacity, 3, 3);
}

std::uint32_t ImperfectVolumes::slotCapacity() const { return impl_->capacity; }
glm::uvec2 ImperfectVolumes::lastDroppedVoxels() const { return impl_->dropped; }
TechniqueFrameStatistics ImperfectVolumes::lastFrameStatistics() const {
    TechniqueFrameStatistics s;
    s.voxelsDropped = std::int64_t(impl_->dropped.x) + std::int64_t(impl_->dropped.y);
    return s;
}

glm::uvec2 ImperfectVolumes::downloadVoxelCounts() const {
    glm::uvec2 counts(0u);
    glGetNamedBufferSubData(impl_->counters.id(), 0, GLsizeiptr(sizeof(counts)), &counts);
    return counts;
}

} // namespace lightskin::gi
