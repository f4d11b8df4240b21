// LightSkin on OpenGL 4.5. Texture layouts (one texel per sparse point, index = y * width + x):
//   point position  RGBA32F  xyz world metres, w = Phong exponent k of the point's material
//   point normal    RGBA32F  xyz unit world normal, w = occluder radius (world metres)
//   gather[0..4]    RGBA32F  (L'_d, sum r^2 w_d), (sum (l-x) w_d, W_d), (L'_s, sum r^2 w_s),
//                            (sum (l-x) w_s, W_s), (sum (l-x)^2 w_d per axis, sum |l-x|^2 w_s)
//   vpl[0..3]       RGBA32F  (L''_d, rbar^2_d), (l'_d, S_o radius), (L''_s, rbar^2_s), (l'_s, S_o radius)
//   occlusion       RGBA32F  x = sum of diffuse occluder amounts, y = glossy (clamped where used)
// Per vertex (SSBO, 4 vec4): (L'''_d, rbar^2), (l'''_d, 0), (L'''_s, rbar^2), (l'''_s, 0), world.
#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/gi/lightskin/LightSkinIllumination.h>
#include <lightskin/gl/ShaderLibrary.h>

#include "common/src/GatherShaders.h"
#include "ValTreeGather.h"

#include <glm/gtc/type_ptr.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <limits>
#include <utility>

namespace lightskin::gi {

namespace {

constexpr int kGatherTargets = 5;
constexpr int kVplTargets = 4;

struct VertexInput {
    glm::vec4 position;
    glm::vec4 normal;
    std::array<std::uint32_t, 8> neighbours;
};
static_assert(sizeof(VertexInput) == 64);

struct GatherProgram {
    gl::Program program;
    GLint valCount = -1, pointCount = -1, eye = -1, c = -1;
};

GatherProgram buildGather(const gl::ShaderLibrary& library, int kCache, bool glossy, bool occlusion, bool nearField) {
    const auto defines = detail::variantDefines(kCache, glossy, occlusion, nearField);
    GatherProgram p;
    p.program = library.buildProgram({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "gather_sparse.frag"}},
                                     defines);
    p.valCount = p.program.uniformLocation("uValCount");
    p.pointCount = p.program.uniformLocation("uPointCount");
    p.eye = p.program.uniformLocation("uEye");
    p.c = p.program.uniformLocation("uC");
    return p;
}

/// Static content, tolerance mode: the result of the change check (std430 block Check of the
/// gather_static_*.comp shaders).
struct StaticCheck {
    float bound = 0.0f;                 ///< sum_j B_j, W/m^2
    std::uint32_t referenceBits = 0;    ///< max L'_d of the last full computation (float bits)
    std::uint32_t badKeys = 0;          ///< VALs of this frame with key >= keyCount
    std::uint32_t referenceBadKeys = 0; ///< the same for the reference set
};
static_assert(sizeof(StaticCheck) == 16);

/// What the last full computation depended on, per instance (see the header's "Static content").
struct InstanceKey {
    const TriangleMesh* mesh = nullptr;
    std::uint32_t meshId = 0;
    glm::mat4 world_T_model{1.0f};
    float specularExponent = 1.0f;
};

} // namespace

struct LightSkinIllumination::Impl {
    LightSkinSettings settings;
    SparsePointProvider provider;
    gl::ShaderLibrary library{embeddedShaders()};

    // Programs: gather variants indexed [glossy][occlusion], occlusion variants [glossy].
    GatherProgram gather[2][2];
    gl::Program gatherCompute[2][2];
    gl::Program renormalise, occlusion[2], interpolate, shade, valSums;
    detail::ValTreeGather treeGather; // valTreeThreshold > 0
    gl::Program cullCount, cullScan, cullScatter, cullAppend; // adaptive VAL culling (gather_cull.glsl)
    gl::Buffer valSumsBuffer; // 2 vec4: (sum l, sum r^2), (sum l^2, count) over all valid VALs
    gl::VertexArray emptyVertexArray;
    gl::GpuStageTimer timer;
    std::vector<gl::StageTime> stageTimes;

    // Prepared data.
    std::vector<SparsePointSet> sparse;
    std::vector<std::uint32_t> sparseOffsets, vertexOffsets;
    std::vector<bool> convex;
    std::uint32_t pointCount = 0, vertexCount = 0;
    int textureWidth = 1, textureHeight = 1;
    gl::Texture pointPosition, pointNormal;
    std::array<gl::Texture, kGatherTargets> gatherTargets;
    std::array<gl::Texture, kVplTargets> vplTargets;
    gl::Texture occlusionTarget;
    gl::Framebuffer gatherFramebuffer, vplFramebuffer, occlusionFramebuffer, shadeFramebuffer;
    gl::Buffer vertexInputs, vertexVpls;
    detail::ValChunkBuffer vals;
    // Adaptive VAL culling: per-VAL slots and per-work-group counts (stable compaction), the kept
    // count; sized for cullCapacity VALs with the VAL buffer.
    gl::Buffer cullSlots, cullGroups, cullCounter;
    std::uint32_t cullCapacity = 0;
    std::uint32_t gatheredCount = 0; // VALs in `vals` at the last full computation
    std::vector<glm::vec4> scratchPositions, scratchNormals;
    LightSkinChoice choice;
    std::string lastReason;

    // Static content: the inputs of the last full computation (valid = one happened since
    // prepare() / setSettings()) and, for the tolerance mode, its VALs in a dense keyed array.
    struct LastComputation {
        bool valid = false;
        std::uint32_t buffer = 0, count = 0;
        std::uint64_t generation = 0;
        glm::vec3 eye{0.0f};
        bool glossy = false, occlusion = false;
        std::uint32_t valsGathered = 0;
        std::string reason;
        bool referenceKeyed = false; ///< denseReference holds its VALs, staticCheck its max L'_d
        std::uint32_t keyCount = 0;
        bool probesValid = false;    ///< probeReference holds its probe gather, staticCheck its max L'_d
    } last;
    std::vector<InstanceKey> lastInstances; // sized in prepare()
    std::string lastStructuralReason;
    gl::Program staticScatter, staticBound, staticSum, staticReference;
    gl::Buffer denseReference, denseCurrent, boundPartials, staticCheck;
    std::uint32_t denseKeyCount = 0;
    // Probes (StaticChangeTest::Probes): every probeStride-th sparse point, sized lazily.
    gl::Program staticProbeCompare;
    std::uint32_t probeCount = 0, probeStride = 0;
    int probeWidth = 1, probeHeight = 1;
    gl::Texture probePosition, probeNormal, probeTarget, probeReference;
    gl::Framebuffer probeFramebuffer;
    std::vector<glm::vec4> probePositions, probeNormals;

    void buildPrograms() {
        for (int g = 0; g < 2; ++g)
            for (int o = 0; o < 2; ++o) {
                gather[g][o] = buildGather(library, settings.kCache, g != 0, o != 0, settings.nearFieldArea);
                gatherCompute[g][o] = library.buildProgram(
                    {{GL_COMPUTE_SHADER, "gather_sparse.comp"}},
                    detail::variantDefines(settings.kCache, g != 0, o != 0, settings.nearFieldArea));
            }
        renormalise =
            library.buildProgram({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "gather_renormalise.frag"}});
        for (int g = 0; g < 2; ++g)
            occlusion[g] = library.buildProgram(
                {{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "gather_occlusion.frag"}},
                detail::variantDefines(settings.kCache, g != 0, true));
        interpolate = library.buildProgram({{GL_COMPUTE_SHADER, "gather_interpolate.comp"}},
                                           settings.vertexDistanceFloor ? std::vector<std::string>{}
                                                                        : std::vector<std::string>{"LS_VERTEX_DISTANCE_FLOOR 0"});
        shade = library.buildProgram({{GL_VERTEX_SHADER, "gather_shade.vert"}, {GL_FRAGMENT_SHADER, "gather_shade.frag"}});
        cullCount = library.buildProgram({{GL_COMPUTE_SHADER, "gather_cull_count.comp"}});
        cullScan = library.buildProgram({{GL_COMPUTE_SHADER, "gather_cull_scan.comp"}});
        cullScatter = library.buildProgram({{GL_COMPUTE_SHADER, "gather_cull_scatter.comp"}});
        cullAppend = library.buildProgram({{GL_COMPUTE_SHADER, "gather_cull_append.comp"}});
        valSums = library.buildProgram({{GL_COMPUTE_SHADER, "gather_val_sums.comp"}});
        treeGather.buildPrograms(library, settings.nearFieldArea);
        staticScatter = library.buildProgram({{GL_COMPUTE_SHADER, "gather_static_scatter.comp"}});
        staticBound = library.buildProgram({{GL_COMPUTE_SHADER, "gather_static_bound.comp"}});
        staticSum = library.buildProgram({{GL_COMPUTE_SHADER, "gather_static_sum.comp"}});
        staticReference = library.buildProgram({{GL_COMPUTE_SHADER, "gather_static_reference.comp"}});
        staticProbeCompare = library.buildProgram({{GL_COMPUTE_SHADER, "gather_static_probes.comp"}});
    }

    // ---- static content --------------------------------------------------------------------
    /// Everything but the VAL set that stages 0-4 read is as at the last full computation.
    bool sceneUnchanged(std::span<const MeshInstance> instances, const ViewParameters& view,
                        const LightSkinChoice& now) const {
        if (!last.valid || now.glossy != last.glossy || now.occlusion != last.occlusion) return false;
        if (now.glossy && view.cameraPositionWorld != last.eye) return false; // eq. 5 depends on the eye
        for (std::size_t m = 0; m < instances.size(); ++m) {
            const InstanceKey& k = lastInstances[m];
            if (instances[m].mesh != k.mesh || instances[m].meshId != k.meshId ||
                instances[m].world_T_model != k.world_T_model ||
                instances[m].material.specularExponent != k.specularExponent)
                return false;
        }
        return true;
    }

    /// The producer promises identical VALs (or both sets are empty).
    bool valsIdentical(const ValSetView& lights) const {
        if (lights.count == 0 && last.count == 0) return true;
        return lights.generation != 0 && lights.generation == last.generation && lights.buffer == last.buffer &&
               lights.count == last.count;
    }

    /// The tolerance mode can compare this set with the reference (dispatch sizes within limits).
    static bool keyedWithinLimits(const ValSetView& lights) {
        return lights.keys != 0 && lights.keyCount > 0 && lights.keyCount <= 65535u * 256u && lights.count <= 65535u * 64u;
    }

    void recordComputation(const ValSetView& lights, std::span<const MeshInstance> instances, const ViewParameters& view) {
        last.valid = true;
        last.buffer = lights.buffer;
        last.count = lights.count;
        last.generation = lights.generation;
        last.eye = view.cameraPositionWorld;
        last.glossy = choice.glossy;
        last.occlusion = choice.occlusion;
        last.valsGathered = choice.valsGathered;
        last.reason = choice.reason;
        for (std::size_t m = 0; m < instances.size(); ++m)
            lastInstances[m] = {instances[m].mesh, instances[m].meshId, instances[m].world_T_model,
                                instances[m].material.specularExponent};
    }

    /// Sizes the dense keyed arrays (once per key space; logged).
    void reserveDense(std::uint32_t keyCount) {
        if (denseKeyCount == keyCount) return;
        const auto bytes = GLsizeiptr(keyCount) * GLsizeiptr(detail::kValBytes);
        denseReference = gl::Buffer::create(bytes, nullptr, GL_DYNAMIC_STORAGE_BIT);
        denseCurrent = gl::Buffer::create(bytes, nullptr, GL_DYNAMIC_STORAGE_BIT);
        boundPartials = gl::Buffer::create(GLsizeiptr((keyCount + 255) / 256) * GLsizeiptr(sizeof(float)), nullptr, 0);
        denseKeyCount = keyCount;
        last.referenceKeyed = false;
        log::info("lightskin adaptive: static-content check sized for " + std::to_string(keyCount) + " VAL keys (" +
                  std::to_string(2 * bytes / (1 << 20)) + " MiB)");
    }

    /// Clears `dense` and writes the VALs of `lights` at their keys; counts bad keys into
    /// staticCheck.badKeys (cleared first).
    void scatterKeyed(const ValSetView& lights, const gl::Buffer& dense) {
        glClearNamedBufferData(dense.id(), GL_R32F, GL_RED, GL_FLOAT, nullptr);
        const std::uint32_t zero = 0;
        glNamedBufferSubData(staticCheck.id(), offsetof(StaticCheck, badKeys), sizeof zero, &zero);
        if (lights.count == 0) return;
        staticScatter.use();
        glUniform1ui(staticScatter.uniformLocation("uCount"), lights.count);
        glUniform1ui(staticScatter.uniformLocation("uKeyCount"), lights.keyCount);
        glBindBufferRange(GL_SHADER_STORAGE_BUFFER, 0, lights.buffer, 0, GLsizeiptr(lights.count) * detail::kValBytes);
        glBindBufferRange(GL_SHADER_STORAGE_BUFFER, 1, lights.keys, 0, GLsizeiptr(lights.count) * GLsizeiptr(sizeof(std::uint32_t)));
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, dense.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, staticCheck.id());
        glDispatchCompute((lights.count + 63) / 64, 1, 1);
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
    }

    /// The bound of gather_static_bound.comp between the reference and `lights` (one read-back).
    StaticCheck checkChange(const ValSetView& lights) {
        scatterKeyed(lights, denseCurrent);
        const std::uint32_t groups = (lights.keyCount + 255) / 256;
        staticBound.use();
        glUniform1ui(staticBound.uniformLocation("uKeyCount"), lights.keyCount);
        glUniform4fv(staticBound.uniformLocation("uReceiverSphere"), 1, glm::value_ptr(receiverSphere()));
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, denseReference.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, denseCurrent.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, boundPartials.id());
        glDispatchCompute(groups, 1, 1);
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
        staticSum.use();
        glUniform1ui(staticSum.uniformLocation("uPartialCount"), groups);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, staticCheck.id());
        glDispatchCompute(1, 1, 1);
        glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
        StaticCheck result;
        glGetNamedBufferSubData(staticCheck.id(), 0, sizeof result, &result);
        return result;
    }

    /// Probe textures for every stride-th sparse point (re-created when the count changes).
    void reserveProbes(int stride) {
        const std::uint32_t step = std::uint32_t(std::max(stride, 1));
        const std::uint32_t count = (pointCount + step - 1) / step;
        if (count == probeCount && step == probeStride) return;
        probeCount = count;
        probeStride = step;
        probeWidth = std::min<int>(settings.sparseTextureWidth, int(count));
        probeHeight = int((count + std::uint32_t(probeWidth) - 1) / std::uint32_t(probeWidth));
        const auto make = [&] { return gl::Texture::create2D(GL_RGBA32F, probeWidth, probeHeight); };
        probePosition = make();
        probeNormal = make();
        probeTarget = make();
        probeReference = make();
        probeFramebuffer = gl::Framebuffer::create();
        probeFramebuffer.attach(GL_COLOR_ATTACHMENT0, probeTarget);
        probeFramebuffer.checkComplete("LightSkin static-content probes");
        probePositions.assign(std::size_t(probeWidth) * std::size_t(probeHeight), glm::vec4(0.0f));
        probeNormals.assign(probePositions.size(), glm::vec4(0.0f, 0.0f, 1.0f, 0.0f));
        last.probesValid = false;
    }

    /// Copies every probeStride-th uploaded sparse point into the probe textures.
    void uploadProbes() {
        for (std::uint32_t i = 0; i < probeCount; ++i) {
            probePositions[i] = scratchPositions[std::size_t(i) * probeStride];
            probeNormals[i] = scratchNormals[std::size_t(i) * probeStride];
        }
        glTextureSubImage2D(probePosition.id(), 0, 0, 0, probeWidth, probeHeight, GL_RGBA, GL_FLOAT, probePositions.data());
        glTextureSubImage2D(probeNormal.id(), 0, 0, 0, probeWidth, probeHeight, GL_RGBA, GL_FLOAT, probeNormals.data());
    }

    /// The diffuse gather (the gather pass itself, diffuse variant) of the first `count` VALs of
    /// `vals` at the probes into probeTarget (L'_d; the other outputs have no attachment). Leaves
    /// texture units 8/9 bound to the main sparse-point textures.
    void gatherProbes(std::uint32_t count, const ViewParameters& view) {
        const float zeros[4] = {0.0f, 0.0f, 0.0f, 0.0f};
        glClearNamedFramebufferfv(probeFramebuffer.id(), GL_COLOR, 0, zeros);
        if (count > 0) {
            const GatherProgram& p = gather[0][0];
            p.program.use();
            glUniform1i(p.pointCount, int(probeCount));
            glUniform3fv(p.eye, 1, glm::value_ptr(view.cameraPositionWorld));
            glUniform1f(p.c, settings.cParameter);
            glBindFramebuffer(GL_FRAMEBUFFER, probeFramebuffer.id());
            glViewport(0, 0, probeWidth, probeHeight);
            glBindVertexArray(emptyVertexArray.id());
            glBindTextureUnit(8, probePosition.id());
            glBindTextureUnit(9, probeNormal.id());
            // The running-sum protocol of the main gather (no blending, gather_sum_block.glsl): the
            // pass reads L'_d from the probe target it writes. Units 1-4 (sums without a target
            // here) keep the main targets: read at probe texels, never written by this pass.
            glBindTextureUnit(0, probeTarget.id());
            const std::uint32_t chunks = vals.chunkCount(count);
            for (std::uint32_t c = 0; c < chunks; ++c) {
                vals.bindChunk(c);
                glUniform1i(p.valCount, int(vals.chunkSize(c, count)));
                glTextureBarrier();
                glDrawArrays(GL_TRIANGLES, 0, 3);
            }
            glBindTextureUnit(0, gatherTargets[0].id());
        }
        glBindTextureUnit(8, pointPosition.id());
        glBindTextureUnit(9, pointNormal.id());
        glViewport(0, 0, textureWidth, textureHeight);
    }

    /// Probe check: re-gathers the probes with `lights` and returns max |L'_d,new - L'_d,ref|
    /// over probes and channels in StaticCheck::bound (one read-back).
    StaticCheck checkProbes(const ValSetView& lights, const ViewParameters& view) {
        vals.copyFrom(lights.buffer, lights.count);
        glMemoryBarrier(GL_UNIFORM_BARRIER_BIT);
        gatherProbes(lights.count, view);
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        const std::uint32_t zero = 0;
        glNamedBufferSubData(staticCheck.id(), offsetof(StaticCheck, bound), sizeof zero, &zero);
        staticProbeCompare.use();
        glUniform1i(staticProbeCompare.uniformLocation("uProbeCount"), int(probeCount));
        glBindTextureUnit(0, probeTarget.id());
        glBindTextureUnit(1, probeReference.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, staticCheck.id());
        glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT);
        glDispatchCompute((probeCount + 63) / 64, 1, 1);
        glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
        StaticCheck result;
        glGetNamedBufferSubData(staticCheck.id(), 0, sizeof result, &result);
        return result;
    }

    /// After a gather: max L'_d into staticCheck.referenceBits.
    void measureReference() {
        const std::uint32_t zero = 0;
        glNamedBufferSubData(staticCheck.id(), offsetof(StaticCheck, referenceBits), sizeof zero, &zero);
        staticReference.use();
        glUniform1i(staticReference.uniformLocation("uPointCount"), int(pointCount));
        glBindTextureUnit(0, gatherTargets[0].id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, staticCheck.id());
        glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT);
        glDispatchCompute((pointCount + 63) / 64, 1, 1);
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
    }

    /// 5. Per-pixel shading (every frame, also when the VPLs are reused).
    void shadePixels(std::span<const MeshInstance> instances, const GBufferView& gbuffer, const ViewParameters& view,
                     std::uint32_t targetTexture) {
        detail::shadeVertexVpls(shade, vertexVpls.id(), vertexOffsets, instances, gbuffer, view,
                                settings.shadingPositionTolerance, choice.glossy, targetTexture, shadeFramebuffer);
    }

    /// Logs the adaptive choice when it changes (reuse toggles alone only at debug level in the
    /// tolerance mode, where they may alternate frame by frame).
    void logChoice(const std::string& structural) {
        if (choice.reason == lastReason) return;
        const std::string message =
            "lightskin adaptive: " + (choice.reason.empty() ? std::string("everything on") : choice.reason);
        if (structural == lastStructuralReason && settings.staticTolerance > 0.0f) log::debug(message);
        else log::info(message);
        lastReason = choice.reason;
        lastStructuralReason = structural;
    }

    void readTexels(const gl::Texture& texture, std::vector<glm::vec4>& all) const {
        all.resize(std::size_t(textureWidth) * std::size_t(textureHeight));
        glGetTextureImage(texture.id(), 0, GL_RGBA, GL_FLOAT, GLsizei(all.size() * sizeof(glm::vec4)), all.data());
    }

    void readInterleaved(std::span<const gl::Texture* const> textures, std::vector<glm::vec4>& out) const {
        const std::size_t stride = textures.size();
        out.assign(std::size_t(pointCount) * stride, glm::vec4(0.0f));
        if (pointCount == 0) return; // nothing prepared: no textures
        std::vector<glm::vec4> all;
        for (std::size_t t = 0; t < stride; ++t) {
            readTexels(*textures[t], all);
            for (std::size_t i = 0; i < pointCount; ++i) out[i * stride + t] = all[i];
        }
    }

    /// What prepare() sizes for its meshes, released when it is given none.
    void releasePreparedResources() {
        pointPosition = {};
        pointNormal = {};
        for (gl::Texture& target : gatherTargets) target = {};
        for (gl::Texture& target : vplTargets) target = {};
        occlusionTarget = {};
        gatherFramebuffer = {};
        vplFramebuffer = {};
        occlusionFramebuffer = {};
        shadeFramebuffer = {};
        vertexInputs = {};
        vertexVpls = {};
        scratchPositions = {};
        scratchNormals = {};
    }

    void uploadPoints(std::span<const MeshInstance> instances) {
        std::size_t at = 0;
        for (std::size_t m = 0; m < instances.size(); ++m) {
            const glm::mat4& transform = instances[m].world_T_model;
            const glm::mat3 linear(transform);
            const glm::mat3 normalMatrix = glm::transpose(glm::inverse(linear));
            const float scale = std::cbrt(std::abs(glm::determinant(linear)));
            const float k = std::max(instances[m].material.specularExponent, 1.0f);
            for (const SparsePoint& p : sparse[m].points) {
                scratchPositions[at] = glm::vec4(glm::vec3(transform * glm::vec4(p.position, 1.0f)), k);
                scratchNormals[at] = glm::vec4(glm::normalize(normalMatrix * p.normal), p.occluderRadius * scale);
                ++at;
            }
        }
        glTextureSubImage2D(pointPosition.id(), 0, 0, 0, textureWidth, textureHeight, GL_RGBA, GL_FLOAT,
                            scratchPositions.data());
        glTextureSubImage2D(pointNormal.id(), 0, 0, 0, textureWidth, textureHeight, GL_RGBA, GL_FLOAT,
                            scratchNormals.data());
    }

    // ---- adaptive VAL culling ---------------------------------------------------------------
    static constexpr std::uint32_t kCullGroup = 256; // CULL_GROUP_SIZE of gather_cull.glsl
    static constexpr std::uint32_t kMaxGroupsPerDispatch = 65535; // GL 4.5 minimum of GL_MAX_COMPUTE_WORK_GROUP_COUNT

    void reserveCull(std::uint32_t capacity) {
        cullCapacity = std::max(capacity, 1u);
        const std::uint32_t groups = (cullCapacity + kCullGroup - 1) / kCullGroup;
        cullSlots = gl::Buffer::create(GLsizeiptr(cullCapacity) * GLsizeiptr(sizeof(std::uint32_t)), nullptr, 0);
        cullGroups = gl::Buffer::create(GLsizeiptr(groups) * GLsizeiptr(sizeof(std::uint32_t)), nullptr, 0);
    }

    /// Copies the `count` VALs of `source` that can reach a receiver into `vals`, in their input
    /// order (stable: count, scan, scatter; gather_cull.glsl) or, with !settings.stableCull, in
    /// atomic-append order; leaves the kept count in cullCounter. Needs cullCapacity, vals.capacity() >= count.
    void cullVals(std::uint32_t source, std::uint32_t count) {
        const glm::vec4 sphere = receiverSphere();
        const GLsizeiptr sourceBytes = GLsizeiptr(count) * detail::kValBytes;
        const std::uint32_t groups = (count + kCullGroup - 1) / kCullGroup;
        glBindBufferRange(GL_SHADER_STORAGE_BUFFER, 0, source, 0, sourceBytes);
        if (!settings.stableCull) {
            const std::uint32_t zero = 0;
            glNamedBufferSubData(cullCounter.id(), 0, sizeof zero, &zero);
            cullAppend.use();
            glUniform1ui(cullAppend.uniformLocation("uCount"), count);
            glUniform4fv(cullAppend.uniformLocation("uReceiverSphere"), 1, glm::value_ptr(sphere));
            glUniform1f(cullAppend.uniformLocation("uInfluenceCutoff"), settings.valInfluenceCutoff);
            glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, cullCounter.id());
            glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, vals.buffer().id());
            for (std::uint32_t first = 0; first < groups; first += kMaxGroupsPerDispatch) {
                glUniform1ui(cullAppend.uniformLocation("uGroupFirst"), first);
                glDispatchCompute(std::min(groups - first, kMaxGroupsPerDispatch), 1, 1);
            }
            return;
        }
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, cullSlots.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, cullGroups.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, cullCounter.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, vals.buffer().id());
        cullCount.use();
        glUniform1ui(cullCount.uniformLocation("uCount"), count);
        glUniform4fv(cullCount.uniformLocation("uReceiverSphere"), 1, glm::value_ptr(sphere));
        glUniform1f(cullCount.uniformLocation("uInfluenceCutoff"), settings.valInfluenceCutoff);
        for (std::uint32_t first = 0; first < groups; first += kMaxGroupsPerDispatch) {
            glUniform1ui(cullCount.uniformLocation("uGroupFirst"), first);
            glDispatchCompute(std::min(groups - first, kMaxGroupsPerDispatch), 1, 1);
        }
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
        cullScan.use();
        glUniform1ui(cullScan.uniformLocation("uGroups"), groups);
        glDispatchCompute(1, 1, 1);
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
        cullScatter.use();
        glUniform1ui(cullScatter.uniformLocation("uCount"), count);
        for (std::uint32_t first = 0; first < groups; first += kMaxGroupsPerDispatch) {
            glUniform1ui(cullScatter.uniformLocation("uGroupFirst"), first);
            glDispatchCompute(std::min(groups - first, kMaxGroupsPerDispatch), 1, 1);
        }
    }

    glm::vec4 receiverSphere() const {
        glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
        for (std::size_t i = 0; i < pointCount; ++i) {
            lo = glm::min(lo, glm::vec3(scratchPositions[i]));
            hi = glm::max(hi, glm::vec3(scratchPositions[i]));
        }
        const glm::vec3 centre = 0.5f * (lo + hi);
        return glm::vec4(centre, glm::length(hi - centre) * 1.0001f + 1e-6f);
    }
};

LightSkinIllumination::LightSkinIllumination() : impl_(std::make_unique<Impl>()) {}
LightSkinIllumination::~LightSkinIllumination() = default;

std::unique_ptr<LightSkinIllumination> LightSkinIllumination::create(const LightSkinSettings& settings,
                                                                     SparsePointProvider provider) {
    LIGHTSKIN_ASSERT(bool(provider), "lightskin::gi::LightSkinIllumination::create(): a sparse point provider is required");
    detail::ValChunkBuffer::validateKCache(settings.kCache, "LightSkinSettings.kCache");
    if (!(settings.valTreeThreshold >= 0.0f && std::isfinite(settings.valTreeThreshold)))
        throw Error("LightSkinSettings.valTreeThreshold", std::nullopt,
                    "must be finite and >= 0, got " + std::to_string(settings.valTreeThreshold));
    std::unique_ptr<LightSkinIllumination> technique(new LightSkinIllumination());
    Impl& impl = *technique->impl_;
    impl.settings = settings;
    impl.provider = std::move(provider);
    impl.buildPrograms();
    impl.emptyVertexArray = gl::VertexArray::create();
    impl.timer = gl::GpuStageTimer::create(8);
    impl.vals.reserve(settings.valCapacity, settings.kCache);
    impl.cullCounter = gl::Buffer::create(sizeof(std::uint32_t), nullptr, GL_DYNAMIC_STORAGE_BIT);
    impl.reserveCull(settings.valCapacity);
    impl.valSumsBuffer = gl::Buffer::create(2 * sizeof(glm::vec4), nullptr, GL_DYNAMIC_STORAGE_BIT);
    impl.staticCheck = gl::Buffer::create(sizeof(StaticCheck), nullptr, GL_DYNAMIC_STORAGE_BIT);
    return technique;
}

const LightSkinSettings& LightSkinIllumination::settings() const noexcept { return impl_->settings; }
const LightSkinChoice& LightSkinIllumination::lastChoice() const noexcept { return impl_->choice; }

TechniqueCapabilities LightSkinIllumination::capabilities() const noexcept {
    return {.glossy = true, .occlusion = true, .sparsePoints = true, .vertexVpls = true, .cpuStages = {}};
}

TechniqueFrameStatistics LightSkinIllumination::lastFrameStatistics() const {
    TechniqueFrameStatistics s;
    if (impl_->settings.adaptive) {
        s.reused = impl_->choice.reused ? 1 : 0;
        s.changeMeasure = impl_->choice.staticChangeBound;
    }
    return s;
}
const std::vector<SparsePointSet>& LightSkinIllumination::sparsePoints() const noexcept { return impl_->sparse; }
const std::vector<std::uint32_t>& LightSkinIllumination::sparseOffsets() const noexcept { return impl_->sparseOffsets; }
const std::vector<std::uint32_t>& LightSkinIllumination::vertexOffsets() const noexcept { return impl_->vertexOffsets; }

void LightSkinIllumination::setSettings(const LightSkinSettings& settings) {
    detail::ValChunkBuffer::validateKCache(settings.kCache, "LightSkinSettings.kCache");
    if (!(settings.valTreeThreshold >= 0.0f && std::isfinite(settings.valTreeThreshold)))
        throw Error("LightSkinSettings.valTreeThreshold", std::nullopt,
                    "must be finite and >= 0, got " + std::to_string(settings.valTreeThreshold));
    // the variants bake kCache, G8 and G12 in as #defines
    const bool rebuild = settings.kCache != impl_->settings.kCache ||
                         settings.vertexDistanceFloor != impl_->settings.vertexDistanceFloor ||
                         settings.nearFieldArea != impl_->settings.nearFieldArea;
    impl_->settings = settings;
    impl_->last.valid = false; // any setting may change stages 0-4
    if (rebuild) {
        impl_->buildPrograms();
        impl_->vals.reserve(std::max(impl_->vals.capacity(), settings.valCapacity), settings.kCache);
    }
}

void LightSkinIllumination::prepare(std::span<const MeshInstance> instances) {
    Impl& impl = *impl_;
    impl.sparse.clear();
    impl.lastInstances.clear();
    impl.sparseOffsets.clear();
    impl.vertexOffsets.clear();
    impl.convex.clear();
    impl.last = {};
    impl.probeCount = 0;
    impl.pointCount = 0;
    impl.vertexCount = 0;
    for (const MeshInstance& instance : instances) {
        LIGHTSKIN_ASSERT(instance.mesh != nullptr, "lightskin::gi::LightSkinIllumination::prepare(): instance without mesh");
        SparsePointSet set = impl.provider(instance);
        const std::string source = "mesh " + std::to_string(instance.meshId);
        if (set.points.empty()) throw Error(source, std::nullopt, "the sparse point provider returned no points");
        if (set.vertexNeighbours.size() != instance.mesh->vertexCount())
            throw Error(source, std::nullopt, "sparse point set has " + std::to_string(set.vertexNeighbours.size()) +
                                                  " neighbour lists for " + std::to_string(instance.mesh->vertexCount()) +
                                                  " vertices");
        for (const auto& list : set.vertexNeighbours)
            for (std::uint32_t index : list)
                if (index >= set.points.size()) throw Error(source, std::nullopt, "neighbour index out of range");
        if (set.tessellationRatio > 1.0f)
            log::warning("lightskin: " + source + " is tessellated coarser than its sparse points (ratio " +
                         std::to_string(set.tessellationRatio) + "): indirect detail will be lost (paper section 6)");
        impl.sparseOffsets.push_back(impl.pointCount);
        impl.vertexOffsets.push_back(impl.vertexCount);
        impl.pointCount += std::uint32_t(set.points.size());
        impl.vertexCount += std::uint32_t(instance.mesh->vertexCount());
        impl.convex.push_back(detail::convexForOcclusion(set));
        impl.lastInstances.emplace_back();
        impl.sparse.push_back(std::move(set));
    }
    if (impl.pointCount == 0) { // no virtual content: valid, GI idle until the next prepare()
        impl.releasePreparedResources();
        impl.gatheredCount = 0;
        log::info("lightskin: prepared no instance: no virtual content, GI idle");
        return;
    }

    impl.textureWidth = std::min<int>(impl.settings.sparseTextureWidth, int(impl.pointCount));
    impl.textureHeight = int((impl.pointCount + std::uint32_t(impl.textureWidth) - 1) / std::uint32_t(impl.textureWidth));
    const std::size_t texels = std::size_t(impl.textureWidth) * std::size_t(impl.textureHeight);
    impl.scratchPositions.assign(texels, glm::vec4(0.0f));
    impl.scratchNormals.assign(texels, glm::vec4(0.0f, 0.0f, 1.0f, 0.0f));
    auto makeTarget = [&] { return gl::Texture::create2D(GL_RGBA32F, impl.textureWidth, impl.textureHeight); };
    impl.pointPosition = makeTarget();
    impl.pointNormal = makeTarget();
    impl.gatherFramebuffer = gl::Framebuffer::create();
    impl.vplFramebuffer = gl::Framebuffer::create();
    impl.occlusionFramebuffer = gl::Framebuffer::create();
    impl.shadeFramebuffer = gl::Framebuffer::create();
    std::array<GLenum, 8> drawBuffers{};
    for (int i = 0; i < kGatherTargets; ++i) {
        impl.gatherTargets[std::size_t(i)] = makeTarget();
        impl.gatherFramebuffer.attach(GLenum(GL_COLOR_ATTACHMENT0 + i), impl.gatherTargets[std::size_t(i)]);
        drawBuffers[std::size_t(i)] = GLenum(GL_COLOR_ATTACHMENT0 + i);
    }
    glNamedFramebufferDrawBuffers(impl.gatherFramebuffer.id(), kGatherTargets, drawBuffers.data());
    impl.gatherFramebuffer.checkComplete("LightSkin gather targets");
    for (int i = 0; i < kVplTargets; ++i) {
        impl.vplTargets[std::size_t(i)] = makeTarget();
        impl.vplFramebuffer.attach(GLenum(GL_COLOR_ATTACHMENT0 + i), impl.vplTargets[std::size_t(i)]);
    }
    glNamedFramebufferDrawBuffers(impl.vplFramebuffer.id(), kVplTargets, drawBuffers.data());
    impl.vplFramebuffer.checkComplete("LightSkin VPL targets");
    impl.occlusionTarget = makeTarget();
    impl.occlusionFramebuffer.attach(GL_COLOR_ATTACHMENT0, impl.occlusionTarget);
    impl.occlusionFramebuffer.checkComplete("LightSkin occlusion target");

    std::vector<VertexInput> inputs;
    inputs.reserve(impl.vertexCount);
    for (std::size_t m = 0; m < instances.size(); ++m) {
        const TriangleMesh& mesh = *instances[m].mesh;
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
            VertexInput in{glm::vec4(mesh.positions[v], 1.0f), glm::vec4(mesh.normals[v], 0.0f), {}};
            for (std::size_t j = 0; j < 8; ++j) in.neighbours[j] = impl.sparse[m].vertexNeighbours[v][j] + impl.sparseOffsets[m];
            inputs.push_back(in);
        }
    }
    impl.vertexInputs = gl::Buffer::create(GLsizeiptr(std::max<std::size_t>(inputs.size(), 1) * sizeof(VertexInput)),
                                           inputs.data(), 0);
    impl.vertexVpls = gl::Buffer::create(GLsizeiptr(std::max<std::uint32_t>(impl.vertexCount, 1)) * 64, nullptr, 0);
    log::info("lightskin: prepared " + std::to_string(instances.size()) + " instance(s), " +
              std::to_string(impl.pointCount) + " sparse points, " + std::to_string(impl.vertexCount) + " vertices");
}

void LightSkinIllumination::render(const ValSetView& lights, std::span<const MeshInstance> instances,
                                   const GBufferView& gbuffer, const ViewParameters& view, std::uint32_t targetTexture) {
    Impl& impl = *impl_;
    const LightSkinSettings& s = impl.settings;
    LIGHTSKIN_ASSERT(instances.size() == impl.sparse.size(),
                     "lightskin::gi::LightSkinIllumination::render(): instances differ from prepare()");
    for (std::size_t m = 0; m < instances.size(); ++m)
        LIGHTSKIN_ASSERT(instances[m].mesh != nullptr && instances[m].mesh->vertexCount() == impl.sparse[m].vertexNeighbours.size(),
                         "lightskin::gi::LightSkinIllumination::render(): instance mesh differs from prepare()");

    if (impl.pointCount == 0) { // prepared without virtual content (prepare() returned early): nothing to light
        glClearTexImage(targetTexture, 0, GL_RGBA, GL_FLOAT, nullptr);
        impl.stageTimes.clear();
        impl.choice = {};
        impl.choice.valsIn = lights.count;
        impl.choice.reason = "no virtual content";
        return;
    }

    // "Model only what the scene requires".
    LightSkinChoice& choice = impl.choice;
    choice.glossy = s.glossy;
    choice.occlusion = s.occlusion;
    choice.valsIn = lights.count;
    choice.reason.clear();
    if (s.adaptive) {
        const bool anySpecular = std::any_of(instances.begin(), instances.end(),
                                             [](const MeshInstance& i) { return i.material.hasSpecular(); });
        if (choice.glossy && !anySpecular) {
            choice.glossy = false;
            choice.reason += "glossy off (no material has f_s); ";
        }
        if (choice.occlusion && instances.size() == 1 && impl.convex[0]) {
            choice.occlusion = false;
            choice.reason += "occlusion off (one convex object); ";
        }
    }

    // gather_val_sums.comp loops count / 256 times per thread: stay below llvmpipe's ~65k limit.
    constexpr std::uint32_t kMaxVals = 256u * 60000u;
    if (lights.count > kMaxVals)
        throw Error("ValSetView", std::nullopt, std::to_string(lights.count) + " VALs exceed the supported " +
                                                    std::to_string(kMaxVals) + " (increase the VAL stride)");

    impl.timer.beginFrame();
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_BLEND);

    impl.timer.begin("upload");
    // Static content: reuse the last full computation's VPLs when nothing stages 0-4 read changed.
    choice.reused = false;
    choice.staticChangeBound = -1.0f;
    const bool reuseEnabled = s.adaptive && s.reuseStatic;
    const bool toleranceMode = reuseEnabled && s.staticTolerance > 0.0f && !choice.glossy;
    const bool useProbes = s.staticChangeTest == StaticChangeTest::Probes;
    const bool keepReference = toleranceMode && !useProbes && Impl::keyedWithinLimits(lights);
    const bool keepProbeReference = toleranceMode && useProbes;
    bool referenceScattered = false;
    const char* reuseReason = "";
    if (reuseEnabled && impl.sceneUnchanged(instances, view, choice)) {
        if (impl.valsIdentical(lights)) {
            choice.reused = true;
            reuseReason = "VPLs reused (static content, identical inputs); ";
        } else if (keepReference && impl.last.referenceKeyed && lights.keyCount == impl.last.keyCount) {
            const StaticCheck check = impl.checkChange(lights);
            const float reference = std::bit_cast<float>(check.referenceBits);
            choice.staticChangeBound = reference > 0.0f ? check.bound / reference
                                                        : (check.bound == 0.0f ? 0.0f : std::numeric_limits<float>::infinity());
            // 1.001: float rounding of the bound's own sum (positive terms, tree reduction)
            if (check.badKeys == 0 && check.referenceBadKeys == 0 && check.bound * 1.001f <= s.staticTolerance * reference) {
                choice.reused = true;
                reuseReason = "VPLs reused (VAL change within staticTolerance); ";
            } else {
                // this frame's dense set becomes the reference of the full computation below
                std::swap(impl.denseReference, impl.denseCurrent);
                glCopyNamedBufferSubData(impl.staticCheck.id(), impl.staticCheck.id(), offsetof(StaticCheck, badKeys),
                                         offsetof(StaticCheck, referenceBadKeys), sizeof(std::uint32_t));
                referenceScattered = true;
            }
        } else if (keepProbeReference && impl.last.probesValid) {
            const StaticCheck check = impl.checkProbes(lights, view);
            const float reference = std::bit_cast<float>(check.referenceBits);
            choice.staticChangeBound = reference > 0.0f ? check.bound / reference
                                                        : (check.bound == 0.0f ? 0.0f : std::numeric_limits<float>::infinity());
            if (check.bound <= s.staticTolerance * reference) {
                choice.reused = true;
                reuseReason = "VPLs reused (probe change within staticTolerance); ";
            }
        }
    }
    if (choice.reused) {
        choice.valsGathered = impl.last.valsGathered;
        choice.reason = impl.last.reason; // what the reused computation chose
        choice.reason += reuseReason;
        impl.timer.end();
        impl.logChoice(impl.last.reason);
        for (const char* stage : {"gather", "normalisation", "occlusion", "interpolation"}) {
            impl.timer.begin(stage);
            impl.timer.end();
        }
        impl.timer.begin("shading");
        impl.shadePixels(instances, gbuffer, view, targetTexture);
        impl.timer.end();
        impl.timer.collect(impl.stageTimes);
        return;
    }
    if (keepReference && !referenceScattered) {
        impl.reserveDense(lights.keyCount);
        impl.scatterKeyed(lights, impl.denseReference);
        glCopyNamedBufferSubData(impl.staticCheck.id(), impl.staticCheck.id(), offsetof(StaticCheck, badKeys),
                                 offsetof(StaticCheck, referenceBadKeys), sizeof(std::uint32_t));
    }
    impl.uploadPoints(instances);
    std::uint32_t count = lights.count;
    // eps_l terms of eq. 7 over ALL valid VALs (before any culling), folded in the renormalisation.
    glClearNamedBufferData(impl.valSumsBuffer.id(), GL_RGBA32F, GL_RGBA, GL_FLOAT, nullptr);
    if (count > 0) {
        impl.valSums.use();
        glUniform1ui(impl.valSums.uniformLocation("uCount"), count);
        glBindBufferRange(GL_SHADER_STORAGE_BUFFER, 0, lights.buffer, 0, GLsizeiptr(count) * detail::kValBytes);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, impl.valSumsBuffer.id());
        glDispatchCompute(1, 1, 1);
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    }
    if (count > 0) {
        if (s.adaptive) {
            if (impl.vals.capacity() < count) impl.vals.reserve(count, s.kCache);
            if (impl.cullCapacity < count) impl.reserveCull(count);
            impl.cullVals(lights.buffer, count);
            glGetNamedBufferSubData(impl.cullCounter.id(), 0, sizeof count, &count);
            if (count < lights.count)
                choice.reason += std::to_string(lights.count - count) + " of " + std::to_string(lights.count) +
                                 " VALs culled (cannot reach a receiver); ";
        } else {
            impl.vals.copyFrom(lights.buffer, count);
        }
    }
    choice.valsGathered = count;
    impl.gatheredCount = count;
    impl.timer.end();
    if (s.adaptive) impl.logChoice(choice.reason);

    // 1. Gather. The second moments (S_o) serve the occlusion and guard G9's extended VPLs.
    const bool moments = choice.occlusion || s.extendedVplHorizon;
    impl.timer.begin("gather");
    const float zeros[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    for (int i = 0; i < kGatherTargets; ++i) glClearNamedFramebufferfv(impl.gatherFramebuffer.id(), GL_COLOR, i, zeros);
    glViewport(0, 0, impl.textureWidth, impl.textureHeight);
    glBindVertexArray(impl.emptyVertexArray.id());
    glBindTextureUnit(8, impl.pointPosition.id());
    glBindTextureUnit(9, impl.pointNormal.id());
    choice.valTreeNodes = 0;
    choice.valTreeCutPerPoint = choice.valTreeVisitedPerPoint = choice.valTreeBuildMs = 0.0f;
    choice.valTreeQuadtree = false;
    if (count > 0 && s.valTreeThreshold > 0.0f && count >= s.valTreeMinVals) {
        std::array<std::uint32_t, kGatherTargets> targets{};
        for (int i = 0; i < kGatherTargets; ++i) targets[std::size_t(i)] = impl.gatherTargets[std::size_t(i)].id();
        // VALs keyed by image pixels (ValGenerator): the image's quadtree over the whole set, whose keys
        // the cull would drop (the cut takes far clusters whole, which is the cull's job); else the BVH.
        const bool image = lights.keys != 0 && lights.keyWidth > 0 && lights.keyCount % lights.keyWidth == 0;
        impl.treeGather.run(image ? lights.buffer : impl.vals.buffer().id(), image ? lights.count : count,
                            image ? lights.keys : 0u, image ? lights.keyWidth : 0u, lights.keyCount, impl.pointCount,
                            impl.pointPosition.id(),
                            impl.pointNormal.id(), targets, view.cameraPositionWorld, s.cParameter, choice.glossy,
                            moments, s.valTreeThreshold, s.valTreeStepsPerDispatch);
        const detail::ValTreeGatherStats& t = impl.treeGather.stats();
        choice.valTreeNodes = t.nodes;
        choice.valTreeBuildMs = float(t.buildMs);
        choice.valTreeQuadtree = t.quadtree;
        const double points = std::max(1.0, double(impl.pointCount));
        choice.valTreeCutPerPoint = float(double(t.taken) / points);
        choice.valTreeVisitedPerPoint = float(double(t.visited) / points);
    } else if (count > 0 && s.computeGather) {
        const gl::Program& p = impl.gatherCompute[choice.glossy ? 1 : 0][moments ? 1 : 0];
        p.use();
        glUniform1i(p.uniformLocation("uPointCount"), int(impl.pointCount));
        glUniform3fv(p.uniformLocation("uEye"), 1, glm::value_ptr(view.cameraPositionWorld));
        glUniform1f(p.uniformLocation("uC"), s.cParameter);
        for (int i = 0; i < kGatherTargets; ++i)
            glBindImageTexture(GLuint(i), impl.gatherTargets[std::size_t(i)].id(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_RGBA32F);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, impl.vals.buffer().id());
        // each thread loops over perDispatch VALs: far below llvmpipe's ~65k iterations
        // a multiple of 64 (one shared-memory tile, four 16-VAL sum blocks): the sums are those
        // of the fragment gather whatever the dispatch size (gather_sum_block.glsl)
        const std::uint32_t perDispatch = std::uint32_t(std::clamp(s.computeValsPerDispatch, 64, 32768)) / 64u * 64u;
        for (std::uint32_t first = 0; first < count; first += perDispatch) {
            glUniform1ui(p.uniformLocation("uValFirst"), first);
            glUniform1ui(p.uniformLocation("uValCount"), std::min(perDispatch, count - first));
            glDispatchCompute((impl.pointCount + 63) / 64, 1, 1);
            glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
        }
        glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT);
    } else if (count > 0) {
        const GatherProgram& p = impl.gather[choice.glossy ? 1 : 0][moments ? 1 : 0];
        p.program.use();
        glUniform1i(p.pointCount, int(impl.pointCount));
        glUniform3fv(p.eye, 1, glm::value_ptr(view.cameraPositionWorld));
        glUniform1f(p.c, s.cParameter);
        glBindFramebuffer(GL_FRAMEBUFFER, impl.gatherFramebuffer.id());
        // Each pass reads its fragment's running sums from the targets it writes (no blending;
        // fixed 16-VAL blocks make the sums independent of K_cache, gather_sum_block.glsl). A
        // texel read and written once by its own fragment is defined (GL 4.5, 9.3.1);
        // glTextureBarrier makes the previous pass's writes visible.
        for (int i = 0; i < kGatherTargets; ++i) glBindTextureUnit(GLuint(i), impl.gatherTargets[std::size_t(i)].id());
        const std::uint32_t chunks = impl.vals.chunkCount(count);
        for (std::uint32_t c = 0; c < chunks; ++c) {
            impl.vals.bindChunk(c);
            glUniform1i(p.valCount, int(impl.vals.chunkSize(c, count)));
            glTextureBarrier();
            glDrawArrays(GL_TRIANGLES, 0, 3);
        }
    }
    if (keepProbeReference) {
        impl.reserveProbes(s.staticProbeStride);
        impl.uploadProbes();
        impl.gatherProbes(count, view); // the same (culled) VALs as the sparse points
        glBindFramebuffer(GL_FRAMEBUFFER, impl.gatherFramebuffer.id());
        glCopyImageSubData(impl.probeTarget.id(), GL_TEXTURE_2D, 0, 0, 0, 0, impl.probeReference.id(), GL_TEXTURE_2D, 0, 0,
                           0, 0, impl.probeWidth, impl.probeHeight, 1);
    }
    if (keepReference || keepProbeReference) impl.measureReference();
    impl.timer.end();

    // 2. Renormalisation.
    impl.timer.begin("normalisation");
    glBindFramebuffer(GL_FRAMEBUFFER, impl.vplFramebuffer.id());
    for (int i = 0; i < kVplTargets; ++i) glClearNamedFramebufferfv(impl.vplFramebuffer.id(), GL_COLOR, i, zeros);
    impl.renormalise.use();
    glUniform1i(impl.renormalise.uniformLocation("uPointCount"), int(impl.pointCount));
    glUniform3fv(impl.renormalise.uniformLocation("uEye"), 1, glm::value_ptr(view.cameraPositionWorld));
    glUniform1f(impl.renormalise.uniformLocation("uEpsilonL"), s.epsilonL);
    glUniform1i(impl.renormalise.uniformLocation("uGlossyOn"), choice.glossy ? 1 : 0);
    glUniform1i(impl.renormalise.uniformLocation("uOcclusionOn"), moments ? 1 : 0);
    glUniform1f(impl.renormalise.uniformLocation("uHorizonSpread"), s.extendedVplHorizon ? 1.0f : 0.0f);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, impl.valSumsBuffer.id());
    for (int i = 0; i < kGatherTargets; ++i) glBindTextureUnit(GLuint(i), impl.gatherTargets[std::size_t(i)].id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    impl.timer.end();

    // 3. Occlusion.
    impl.timer.begin("occlusion");
    glClearNamedFramebufferfv(impl.occlusionFramebuffer.id(), GL_COLOR, 0, zeros);
    if (choice.occlusion) {
        const gl::Program& p = impl.occlusion[choice.glossy ? 1 : 0];
        p.use();
        glUniform1i(p.uniformLocation("uPointCount"), int(impl.pointCount));
        glBindFramebuffer(GL_FRAMEBUFFER, impl.occlusionFramebuffer.id());
        glBindTextureUnit(1, impl.vplTargets[1].id());
        glBindTextureUnit(3, impl.vplTargets[3].id());
        glEnable(GL_BLEND);
        glBlendFunc(GL_ONE, GL_ONE);
        const GLint begin = p.uniformLocation("uOccluderBegin");
        const GLint countLocation = p.uniformLocation("uOccluderCount");
        const std::uint32_t chunk = std::uint32_t(std::clamp(s.occluderChunk, 1, 60000)); // llvmpipe loop limit
        for (std::uint32_t first = 0; first < impl.pointCount; first += chunk) {
            glUniform1i(begin, int(first));
            glUniform1i(countLocation, int(std::min(chunk, impl.pointCount - first)));
            glDrawArrays(GL_TRIANGLES, 0, 3);
        }
        glDisable(GL_BLEND);
    }
    impl.timer.end();

    // 4. Vertex interpolation.
    impl.timer.begin("interpolation");
    impl.interpolate.use();
    for (int i = 0; i < kVplTargets; ++i) glBindTextureUnit(GLuint(i), impl.vplTargets[std::size_t(i)].id());
    glBindTextureUnit(4, impl.occlusionTarget.id());
    glBindTextureUnit(5, impl.gatherTargets[0].id()); // L'_d (G10)
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, impl.vertexInputs.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, impl.vertexVpls.id());
    glUniform1i(impl.interpolate.uniformLocation("uApplyOcclusion"), choice.occlusion ? 1 : 0);
    glUniform1f(impl.interpolate.uniformLocation("uHorizonSpread"), s.extendedVplHorizon ? 1.0f : 0.0f);
    glUniform1i(impl.interpolate.uniformLocation("uIrradianceCap"), s.vertexIrradianceCap ? 1 : 0);
    // G11: the real depth, when handed in, leaves buried sparse points out of eq. 12-13.
    const RealDepthView& realDepth = view.realDepth;
    const bool buriedRule = s.buriedSparsePoints && realDepth.texture != 0;
    glUniform1i(impl.interpolate.uniformLocation("uBuriedRule"), buriedRule ? 1 : 0);
    glBindTextureUnit(6, buriedRule ? realDepth.texture : 0);
    glUniformMatrix4fv(impl.interpolate.uniformLocation("uCameraFromWorld"), 1, GL_FALSE,
                       glm::value_ptr(realDepth.camera_T_world));
    glUniform4fv(impl.interpolate.uniformLocation("uRealIntrinsics"), 1, glm::value_ptr(realDepth.intrinsics));
    for (std::size_t m = 0; m < instances.size(); ++m) {
        const glm::mat3 normalMatrix = glm::transpose(glm::inverse(glm::mat3(instances[m].world_T_model)));
        const std::uint32_t vertices = std::uint32_t(instances[m].mesh->vertexCount());
        glUniformMatrix4fv(impl.interpolate.uniformLocation("uWorldFromModel"), 1, GL_FALSE,
                           glm::value_ptr(instances[m].world_T_model));
        glUniformMatrix3fv(impl.interpolate.uniformLocation("uNormalFromModel"), 1, GL_FALSE, glm::value_ptr(normalMatrix));
        glUniform1ui(impl.interpolate.uniformLocation("uFirstVertex"), impl.vertexOffsets[m]);
        glUniform1ui(impl.interpolate.uniformLocation("uVertexCount"), vertices);
        if (vertices > 0) glDispatchCompute((vertices + 63) / 64, 1, 1);
    }
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    impl.timer.end();

    // 5. Per-pixel shading.
    impl.timer.begin("shading");
    impl.shadePixels(instances, gbuffer, view, targetTexture);
    impl.timer.end();
    if (reuseEnabled) impl.recordComputation(lights, instances, view);
    else impl.last.valid = false;
    impl.last.referenceKeyed = keepReference;
    impl.last.probesValid = keepProbeReference;
    impl.last.keyCount = keepReference ? lights.keyCount : 0;
    impl.timer.collect(impl.stageTimes);
}

void LightSkinIllumination::lastStageTimes(std::vector<gl::StageTime>& out) const { out = impl_->stageTimes; }

void LightSkinIllumination::readGatherSums(std::vector<glm::vec4>& out) const {
    const gl::Texture* t[kGatherTargets];
    for (int i = 0; i < kGatherTargets; ++i) t[i] = &impl_->gatherTargets[std::size_t(i)];
    impl_->readInterleaved(t, out);
    // add the folded eps_l terms (as gather_renormalise.frag does) so that these are eq. 7's sums
    glm::vec4 sums[2];
    glGetNamedBufferSubData(impl_->valSumsBuffer.id(), 0, sizeof sums, sums);
    const float eps = impl_->settings.epsilonL;
    const float n = sums[1].w;
    for (std::size_t i = 0; i < impl_->pointCount; ++i) {
        const glm::vec3 x(impl_->scratchPositions[i]);
        const glm::vec3 offset = eps * (glm::vec3(sums[0]) - n * x);
        const glm::vec3 moment = eps * glm::max(glm::vec3(sums[1]) - 2.0f * x * glm::vec3(sums[0]) + n * x * x, glm::vec3(0.0f));
        glm::vec4* g = &out[kGatherTargets * i];
        g[0].w += eps * sums[0].w;
        g[1] += glm::vec4(offset, eps * n);
        if (impl_->choice.glossy) {
            g[2].w += eps * sums[0].w;
            g[3] += glm::vec4(offset, eps * n);
        }
        if (impl_->choice.occlusion || impl_->settings.extendedVplHorizon)
            g[4] += glm::vec4(moment, impl_->choice.glossy ? moment.x + moment.y + moment.z : 0.0f);
    }
}

void LightSkinIllumination::readSparseVpls(std::vector<glm::vec4>& out) const {
    const gl::Texture* t[kVplTargets];
    for (int i = 0; i < kVplTargets; ++i) t[i] = &impl_->vplTargets[std::size_t(i)];
    impl_->readInterleaved(t, out);
}

void LightSkinIllumination::readOcclusion(std::vector<glm::vec4>& out) const {
    const gl::Texture* t[1] = {&impl_->occlusionTarget};
    impl_->readInterleaved(t, out);
}

void LightSkinIllumination::readVertexVpls(std::vector<glm::vec4>& out) const {
    out.resize(std::size_t(impl_->vertexCount) * 4);
    if (!out.empty())
        glGetNamedBufferSubData(impl_->vertexVpls.id(), 0, GLsizeiptr(out.size() * sizeof(glm::vec4)), out.data());
}

void LightSkinIllumination::readGatheredVals(std::vector<VirtualAreaLight>& out) const {
    out.resize(impl_->gatheredCount);
    if (!out.empty())
        glGetNamedBufferSubData(impl_->vals.buffer().id(), 0, GLsizeiptr(out.size() * sizeof(VirtualAreaLight)), out.data());
}

} // namespace lightskin::gi
