#include "LightsShaders.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/common/ReflectiveShadowMap.h>
#include <lightskin/gl/ShaderLibrary.h>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <cmath>
#include <limits>
#include <numbers>
#include <string>

namespace lightskin::gi {

glm::dvec3 radiantPower(const VirtualLight& light) {
    const double solidAngle = light.type == VirtualLight::Type::Point
                                  ? 4.0 * std::numbers::pi
                                  : 2.0 * std::numbers::pi * (1.0 - std::cos(double(light.spotHalfAngle)));
    return glm::dvec3(light.intensity) * solidAngle;
}

void validate(const RsmSettings& s) {
    const auto fail = [](const char* field, const std::string& why) {
        throw Error(std::string("RsmSettings.") + field, std::nullopt, why);
    };
    if (s.resolution < 1 || s.resolution > 4096) fail("resolution", "must be in [1, 4096]");
    if (s.maxLights < 1 || s.maxLights > 64) fail("maxLights", "must be in [1, 64]");
    const bool automatic = s.nearPlane == 0.0f && s.farPlane == 0.0f;
    if (!automatic && (!(s.nearPlane > 0.0f) || !(s.farPlane > s.nearPlane) || !std::isfinite(s.farPlane)))
        fail("nearPlane/farPlane", "need 0 < near < far < inf, or both 0 (automatic)");
    if (!(s.minCosine > 0.0f && s.minCosine <= 1.0f)) fail("minCosine", "must be in (0, 1]");
    const double vals = double(s.maxLights) * 6.0 * double(s.resolution) * double(s.resolution);
    if (vals > 64.0 * 1024 * 1024) fail("resolution", "maxLights * 6 * resolution^2 exceeds 64M VALs");
}

ReflectiveShadowMap ReflectiveShadowMap::create(const RsmSettings& settings) {
    validate(settings);
    ReflectiveShadowMap r;
    r.settings_ = settings;
    const int n = settings.resolution;
    r.capacity_ = std::uint32_t(settings.maxLights * 6 * n * n);
    const gl::ShaderLibrary library{embeddedShaders()};
    r.rasterProgram_ = library.buildProgram({{GL_VERTEX_SHADER, "rsm.vert"}, {GL_FRAGMENT_SHADER, "rsm.frag"}});
    r.compactProgram_ = library.buildProgram({{GL_COMPUTE_SHADER, "rsm_to_vals.comp"}});
    r.position_ = gl::Texture::create2D(GL_RGBA32F, n, n);
    r.normal_ = gl::Texture::create2D(GL_RGBA32F, n, n);
    r.albedo_ = gl::Texture::create2D(GL_RGBA16F, n, n);
    r.depth_ = gl::Renderbuffer::create(GL_DEPTH_COMPONENT32F, n, n);
    r.framebuffer_ = gl::Framebuffer::create();
    r.framebuffer_.attach(GL_COLOR_ATTACHMENT0, r.position_);
    r.framebuffer_.attach(GL_COLOR_ATTACHMENT1, r.normal_);
    r.framebuffer_.attach(GL_COLOR_ATTACHMENT2, r.albedo_);
    r.framebuffer_.attach(GL_DEPTH_ATTACHMENT, r.depth_);
    const GLenum drawBuffers[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
    glNamedFramebufferDrawBuffers(r.framebuffer_.id(), 3, drawBuffers);
    r.framebuffer_.checkComplete("reflective shadow map");
    r.vals_ = gl::Buffer::create(GLsizeiptr(r.capacity_) * GLsizeiptr(sizeof(VirtualAreaLight)));
    r.counter_ = gl::Buffer::create(sizeof(std::uint32_t));
    return r;
}

namespace {

struct Face {
    glm::vec3 forward, up;
};

void checkLight(const VirtualLight& light, std::size_t index) {
    const std::string source = "virtual light " + std::to_string(index);
    const auto finite = [](glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
    if (!finite(light.position) || !finite(light.intensity) || !finite(light.direction))
        throw Error(source, std::nullopt, "non-finite position, direction or intensity");
    if (light.intensity.x < 0.0f || light.intensity.y < 0.0f || light.intensity.z < 0.0f)
        throw Error(source, std::nullopt, "negative intensity");
    if (light.type == VirtualLight::Type::Spot) {
        if (!(glm::length(light.direction) > 0.0f)) throw Error(source, std::nullopt, "spot direction is zero");
        if (!(light.spotHalfAngle > 0.0f && light.spotHalfAngle <= 1.5f))
            throw Error(source, std::nullopt, "spot half-angle must be in (0, 1.5] radians");
    }
}

} // namespace

ValSetView ReflectiveShadowMap::generate(std::span<const VirtualLight> lights, std::span<const MeshInstance> instances) {
    LIGHTSKIN_ASSERT(rasterProgram_, "ReflectiveShadowMap used before create()");
    if (lights.size() > std::size_t(settings_.maxLights))
        throw Error("ReflectiveShadowMap", std::nullopt,
                    std::to_string(lights.size()) + " lights, created for " + std::to_string(settings_.maxLights));
    const std::uint32_t zero = 0;
    glClearNamedBufferData(counter_.id(), GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, &zero);
    const int n = settings_.resolution;
    const float clearZero[4] = {0.f, 0.f, 0.f, 0.f};
    const float clearDepth = 1.0f;

    for (std::size_t l = 0; l < lights.size(); ++l) {
        const VirtualLight& light = lights[l];
        checkLight(light, l);
        Face faces[6];
        int faceCount = 0;
        float tanHalf = 1.0f, minCosAlpha = -1.0f;
        if (light.type == VirtualLight::Type::Spot) {
            const glm::vec3 forward = glm::normalize(light.direction);
            const glm::vec3 up = std::abs(forward.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
            faces[faceCount++] = {forward, up};
            tanHalf = std::tan(light.spotHalfAngle);
            minCosAlpha = std::cos(light.spotHalfAngle);
        } else {
            const glm::vec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
            for (const glm::vec3& axis : axes) faces[faceCount++] = {axis, std::abs(axis.y) < 0.5f ? glm::vec3(0, 1, 0) : glm::vec3(0, 0, 1)};
        }
        float nearPlane = settings_.nearPlane, farPlane = settings_.farPlane;
        if (nearPlane == 0.0f) {
            // Bounding sphere of the placed meshes (box centre, farthest vertex), then the light's
            // distance to it. Double precision: scenes from millimetres to kilometres.
            glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
            for (const MeshInstance& instance : instances) {
                LIGHTSKIN_ASSERT(instance.mesh != nullptr, "automatic RSM frustum needs MeshInstance::mesh");
                const glm::dmat4 world_T_model(instance.world_T_model);
                for (const glm::vec3& p : instance.mesh->positions) {
                    const glm::dvec3 w(world_T_model * glm::dvec4(glm::dvec3(p), 1.0));
                    lo = glm::min(lo, w), hi = glm::max(hi, w);
                }
            }
            if (!(lo.x <= hi.x)) continue; // nothing to render
            const glm::dvec3 centre = 0.5 * (lo + hi);
            const double radius = 0.5 * glm::length(hi - lo);
            const double distance = glm::length(centre - glm::dvec3(light.position));
            farPlane = float((distance + radius) * 1.01 + 1e-30);
            nearPlane = float(std::max(distance - radius, 1e-5 * (distance + radius)) * 0.99);
        }
        const glm::mat4 projection = glm::perspective(2.0f * std::atan(tanHalf), 1.0f, nearPlane, farPlane);
        for (int f = 0; f < faceCount; ++f) {
            const glm::mat4 view = glm::lookAt(light.position, light.position + faces[f].forward, faces[f].up);
            const glm::mat4 clip_T_world = projection * view;
            glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
            glViewport(0, 0, n, n);
            for (int b = 0; b < 3; ++b) glClearNamedFramebufferfv(framebuffer_.id(), GL_COLOR, b, clearZero);
            glClearNamedFramebufferfv(framebuffer_.id(), GL_DEPTH, 0, &clearDepth);
            glEnable(GL_DEPTH_TEST);
            glDepthFunc(GL_LESS);
            glDepthMask(GL_TRUE);
            glDisable(GL_CULL_FACE);
            glDisable(GL_BLEND);
            rasterProgram_.use();
            const GLuint p = rasterProgram_.id();
            glProgramUniformMatrix4fv(p, rasterProgram_.uniformLocation("lightClip_T_world"), 1, GL_FALSE,
                                      glm::value_ptr(clip_T_world));
            glProgramUniform3fv(p, rasterProgram_.uniformLocation("lightPosition"), 1, glm::value_ptr(light.position));
            for (const MeshInstance& instance : instances) {
                glProgramUniformMatrix4fv(p, rasterProgram_.uniformLocation("world_T_model"), 1, GL_FALSE,
                                          glm::value_ptr(instance.world_T_model));
                glProgramUniform3fv(p, rasterProgram_.uniformLocation("diffuseAlbedo"), 1,
                                    glm::value_ptr(instance.material.diffuseAlbedo));
                glBindVertexArray(instance.gpu.vertexArray);
                glDrawElements(GL_TRIANGLES, GLsizei(instance.gpu.indexCount), GL_UNSIGNED_INT, nullptr);
            }
            glBindVertexArray(0);
            glBindFramebuffer(GL_FRAMEBUFFER, 0);
            glDisable(GL_DEPTH_TEST);
            glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT);

            compactProgram_.use();
            const GLuint c = compactProgram_.id();
            glProgramUniform1i(c, compactProgram_.uniformLocation("resolution"), n);
            glProgramUniform1f(c, compactProgram_.uniformLocation("tanHalfAngle"), tanHalf);
            glProgramUniform1f(c, compactProgram_.uniformLocation("minCosAlpha"), minCosAlpha);
            glProgramUniform3fv(c, compactProgram_.uniformLocation("lightPosition"), 1, glm::value_ptr(light.position));
            glProgramUniform3fv(c, compactProgram_.uniformLocation("intensity"), 1, glm::value_ptr(light.intensity));
            glProgramUniform1i(c, compactProgram_.uniformLocation("areaFacingLight"), settings_.areaFacingLight ? 1 : 0);
            glProgramUniform1f(c, compactProgram_.uniformLocation("minCosine"), settings_.minCosine);
            glProgramUniform1ui(c, compactProgram_.uniformLocation("capacity"), capacity_);
            glBindTextureUnit(0, position_.id());
            glBindTextureUnit(1, normal_.id());
            glBindTextureUnit(2, albedo_.id());
            glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, vals_.id());
            glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, counter_.id());
            glDispatchCompute(GLuint((n + 7) / 8), GLuint((n + 7) / 8), 1);
            glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
        }
    }
    std::uint32_t count = 0;
    glGetNamedBufferSubData(counter_.id(), 0, sizeof count, &count);
    lastCount_ = std::min(count, capacity_);
    return lastSet();
}

std::vector<VirtualAreaLight> ReflectiveShadowMap::downloadVals() const {
    std::vector<VirtualAreaLight> out(lastCount_);
    if (lastCount_ > 0)
        glGetNamedBufferSubData(vals_.id(), 0, GLsizeiptr(out.size() * sizeof(VirtualAreaLight)), out.data());
    return out;
}

} // namespace lightskin::gi
