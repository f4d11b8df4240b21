// Set-up shared by the imperfect-volumes GL tests: a one-row G-buffer of receivers and the L1
// projection of the Embree truth's incident light at a receiver.
#pragma once

#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gi/reference/RayTracedGroundTruth.h>
#include <lightskin/gi/common/VirtualAreaLight.h>
#include <lightskin/gl/Objects.h>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <span>

namespace lightskin::test {

/// Receivers in one row of RGBA32F textures (world position w = 1, unit normal, albedo), and an
/// RGBA32F output of the same size. Owns the textures; view() refers to them.
struct ReceiverRow {
    gl::Texture position, normal, albedo, output;
    int count = 0;

    /// All three spans hold the same number (> 0) of receivers.
    static ReceiverRow create(std::span<const glm::vec4> positions, std::span<const glm::vec4> normals,
                              std::span<const glm::vec4> albedos) {
        ReceiverRow row;
        row.count = int(positions.size());
        const auto upload = [&](std::span<const glm::vec4> texels) {
            gl::Texture texture = gl::Texture::create2D(GL_RGBA32F, row.count, 1);
            glTextureSubImage2D(texture.id(), 0, 0, 0, row.count, 1, GL_RGBA, GL_FLOAT, texels.data());
            return texture;
        };
        row.position = upload(positions);
        row.normal = upload(normals);
        row.albedo = upload(albedos);
        row.output = gl::Texture::create2D(GL_RGBA32F, row.count, 1);
        return row;
    }

    gi::GBufferView view() const {
        gi::GBufferView gbuffer;
        gbuffer.worldPosition = position.id();
        gbuffer.worldNormal = normal.id();
        gbuffer.diffuseAlbedo = albedo.id();
        gbuffer.width = count;
        gbuffer.height = 1;
        return gbuffer;
    }
};

struct IncidentL1 {
    double l1 = 0.0;        ///< integral of L_vis (1/4 + mu/2): the L1 irradiance of the truth's radiance
    double exact = 0.0;     ///< integral of L_vis max(0, mu): the irradiance
    double bandBound = 0.0; ///< integral of L_unoccluded |1/4 + mu/2 - max(0, mu)| >= |l1 - exact|
};

/// Red channel at receiver p (normal n), every VAL with its Embree visibility from p + shadowOffset n.
/// Small-disc solid angle A cos(theta_j) / d^2 per VAL: relative error O((r / d)^2), which each caller
/// bounds for its scene. The L1 kernel: pi Y00^2 + 2 pi / 3 Y1(w) . Y1(n) = 1/4 + (n . w) / 2.
inline IncidentL1 incidentL1(const gi::RayTracedGroundTruth& rt, std::span<const gi::VirtualAreaLight> vals,
                             const glm::dvec3& p, const glm::dvec3& n, double shadowOffset) {
    IncidentL1 out;
    for (const auto& val : vals) {
        const glm::dvec3 y(val.position), toY = y - p;
        const double d2 = glm::dot(toY, toY), d = std::sqrt(d2);
        const glm::dvec3 w = toY / d;
        const double cosJ = -glm::dot(glm::dvec3(val.normal), w);
        if (cosJ <= 0.0) continue;
        const double radiance = double(val.flux.x) / (std::numbers::pi * double(val.area));
        const double omegaL = radiance * double(val.area) * cosJ / d2;
        const double mu = glm::dot(n, w);
        out.bandBound += omegaL * std::abs(0.25 + 0.5 * mu - std::max(0.0, mu));
        if (rt.occluded(p + shadowOffset * n, y)) continue;
        out.l1 += omegaL * (0.25 + 0.5 * mu);
        out.exact += omegaL * std::max(0.0, mu);
    }
    return out;
}

} // namespace lightskin::test
