// Double-precision reference of the LightSkin stages: loops and bookkeeping only; every formula
// comes from lightskin_math.glsl through LightSkinMath.h.
#include "lightskin/src/LightSkinMath.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/reference/LightSkinReference.h>

#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

#include <algorithm>
#include <limits>

namespace lightskin::gi::reference {

namespace m = refmath;

namespace {
glm::dvec3 d3(const glm::vec3& v) { return glm::dvec3(v); }

m::Vpl toMath(const Vpl& v) {
    m::Vpl r;
    r.radiance = v.radiance;
    r.r2 = v.r2;
    r.position = v.position;
    r.sphereRadius = v.sphereRadius;
    return r;
}
Vpl fromMath(const m::Vpl& v) { return Vpl{v.radiance, v.r2, v.position, v.sphereRadius}; }
} // namespace

std::vector<Receiver> receiversFromSparsePoints(const SparsePointSet& points, const glm::mat4& world_T_model,
                                                double exponent) {
    const glm::dmat4 transform(world_T_model);
    const glm::dmat3 linear(transform);
    const glm::dmat3 normalMatrix = glm::transpose(glm::inverse(linear));
    const double scale = std::cbrt(std::abs(glm::determinant(linear)));
    std::vector<Receiver> out;
    out.reserve(points.points.size());
    for (const SparsePoint& p : points.points) {
        Receiver r;
        r.position = glm::dvec3(transform * glm::dvec4(d3(p.position), 1.0));
        r.normal = glm::normalize(normalMatrix * d3(p.normal));
        r.exponent = exponent;
        r.occluderRadius = double(p.occluderRadius) * scale;
        out.push_back(r);
    }
    return out;
}

void gatherInto(std::span<const VirtualAreaLight> lights, std::span<const Receiver> receivers, const glm::dvec3& eye,
                const GatherParameters& parameters, std::vector<GatherSums>& out) {
    out.assign(receivers.size(), GatherSums{});
    for (std::size_t i = 0; i < receivers.size(); ++i) {
        const Receiver& x = receivers[i];
        const glm::dvec3 toEye = m::ls_toEye(x.position, eye);
        const double ck = parameters.cParameter * (x.exponent + 1.0);
        GatherSums& s = out[i];
        for (const VirtualAreaLight& l : lights) {
            const m::GatherSample g =
                m::ls_gatherSample(x.position, x.normal, d3(l.position), d3(l.normal), double(l.area), d3(l.flux),
                                   toEye, x.exponent, ck, parameters.epsilonL, parameters.nearField);
            s.irradiance += g.irradiance;
            s.weightD += g.weightD;
            s.offsetD += g.offset * g.weightD;
            s.r2D += g.r2 * g.weightD;
            s.momentD += g.offset * g.offset * g.weightD;
            if (parameters.glossy) {
                s.glossy += g.glossy;
                s.weightS += g.weightS;
                s.offsetS += g.offset * g.weightS;
                s.r2S += g.r2 * g.weightS;
                s.momentS += glm::dot(g.offset, g.offset) * g.weightS;
            }
        }
    }
}

void renormaliseInto(std::span<const GatherSums> sums, std::span<const Receiver> receivers, const glm::dvec3& eye,
                     std::vector<VplPair>& out) {
    LIGHTSKIN_ASSERT(sums.size() == receivers.size(), "one GatherSums per receiver");
    out.resize(sums.size());
    for (std::size_t i = 0; i < sums.size(); ++i) {
        const GatherSums& s = sums[i];
        const Receiver& x = receivers[i];
        out[i].diffuse = fromMath(
            m::ls_renormaliseDiffuse(s.irradiance, s.offsetD, s.weightD, s.r2D, s.momentD, x.position, x.normal, 1.0));
        out[i].diffuseCap = m::ls_peakChannel(s.irradiance); // G10
        out[i].glossy = fromMath(m::ls_renormaliseGlossy(s.glossy, s.offsetS, s.weightS, s.r2S, s.momentS, x.position,
                                                         x.normal, m::ls_toEye(x.position, eye), x.exponent));
    }
}

void occlusionInto(std::span<const Receiver> receivers, std::span<const VplPair> vpls, std::vector<glm::dvec2>& out) {
    LIGHTSKIN_ASSERT(vpls.size() == receivers.size(), "one VplPair per receiver");
    out.assign(receivers.size(), glm::dvec2(0.0));
    for (std::size_t i = 0; i < receivers.size(); ++i) {
        const Receiver& x = receivers[i];
        const glm::dvec3 t = m::ls_tangent(x.normal);
        const glm::dvec3 b = m::ls_binormal(x.normal);
        const m::OcclusionTarget targetD =
            m::ls_occlusionTarget(x.position, x.normal, t, b, vpls[i].diffuse.position, vpls[i].diffuse.sphereRadius);
        const m::OcclusionTarget targetS =
            m::ls_occlusionTarget(x.position, x.normal, t, b, vpls[i].glossy.position, vpls[i].glossy.sphereRadius);
        glm::dvec2 sum(0.0);
        for (const Receiver& y : receivers) {
            sum.x += m::ls_occluderAmount(targetD, x.position, x.normal, t, b, y.position, y.normal, y.occluderRadius);
            sum.y += m::ls_occluderAmount(targetS, x.position, x.normal, t, b, y.position, y.normal, y.occluderRadius);
        }
        out[i] = glm::clamp(sum, 0.0, 1.0);
    }
}

void applyOcclusion(std::span<const glm::dvec2> occlusion, std::vector<VplPair>& vpls) {
    LIGHTSKIN_ASSERT(occlusion.size() == vpls.size(), "one occlusion value per VPL pair");
    for (std::size_t i = 0; i < vpls.size(); ++i) {
        vpls[i].diffuse.radiance *= 1.0 - occlusion[i].x;
        vpls[i].diffuseCap *= 1.0 - occlusion[i].x;
        vpls[i].glossy.radiance *= 1.0 - occlusion[i].y;
    }
}

void interpolateVerticesInto(std::span<const glm::dvec3> vertexPositions, std::span<const glm::dvec3> vertexNormals,
                             std::span<const std::array<std::uint32_t, kVertexNeighbours>> neighbours,
                             std::span<const Receiver> sparseReceivers, std::span<const VplPair> sparse,
                             std::vector<VplPair>& out, bool irradianceCap,
                             std::span<const std::uint8_t> sparseBuried) {
    LIGHTSKIN_ASSERT(vertexPositions.size() == vertexNormals.size() && vertexPositions.size() == neighbours.size(),
                     "one normal and one neighbour list per vertex");
    LIGHTSKIN_ASSERT(sparseBuried.empty() || sparseBuried.size() == sparseReceivers.size(),
                     "one buried flag per sparse point, or none");
    out.resize(vertexPositions.size());
    for (std::size_t v = 0; v < vertexPositions.size(); ++v) {
        double dist[kVertexNeighbours];
        double cosN[kVertexNeighbours];
        bool unique[kVertexNeighbours];
        bool buried[kVertexNeighbours];
        for (std::size_t j = 0; j < std::size_t(kVertexNeighbours); ++j) {
            const std::uint32_t index = neighbours[v][j];
            LIGHTSKIN_ASSERT(index < sparseReceivers.size(), "neighbour index out of range");
            dist[j] = glm::length(vertexPositions[v] - sparseReceivers[index].position);
            cosN[j] = glm::dot(vertexNormals[v], sparseReceivers[index].normal);
            unique[j] = j == 0 || index != neighbours[v][j - 1];
            buried[j] = !sparseBuried.empty() && sparseBuried[index] != 0; // G11
        }
        const m::VertexWeights weights = m::ls_vertexWeightsAboveSurface(dist, cosN, unique, buried);
        VplPair r{};
        double minDD = std::numeric_limits<double>::max(), minDS = std::numeric_limits<double>::max(); // G8
        double cap = 0.0;                                                                              // G10
        for (std::size_t j = 0; j < std::size_t(kVertexNeighbours); ++j) {
            const double w = weights.w[j];
            if (w == 0.0) continue;
            const VplPair& s = sparse[neighbours[v][j]];
            const glm::dvec3 x = sparseReceivers[neighbours[v][j]].position;
            minDD = std::min(minDD, glm::dot(s.diffuse.position - x, s.diffuse.position - x) + s.diffuse.r2);
            minDS = std::min(minDS, glm::dot(s.glossy.position - x, s.glossy.position - x) + s.glossy.r2);
            cap = s.diffuseCap < 0.0 || cap < 0.0 ? -1.0 : std::max(cap, s.diffuseCap); // G10 (< 0: unknown)
            r.diffuse.radiance += w * s.diffuse.radiance;
            r.diffuse.r2 += w * s.diffuse.r2;
            r.diffuse.position += w * s.diffuse.position;
            r.diffuse.sphereRadius += w * s.diffuse.sphereRadius; // G9: the spread of the shaded VPL
            r.glossy.radiance += w * s.glossy.radiance;
            r.glossy.r2 += w * s.glossy.r2;
            r.glossy.position += w * s.glossy.position;
        }
        r.diffuse.r2 = m::ls_vertexR2Floor(r.diffuse.r2, vertexPositions[v], r.diffuse.position, minDD);
        r.glossy.r2 = m::ls_vertexR2Floor(r.glossy.r2, vertexPositions[v], r.glossy.position, minDS);
        r.diffuseCap = irradianceCap ? cap : -1.0;
        out[v] = r;
    }
}

glm::dvec3 shade(const VplPair& vpl, const Surface& surface, const glm::dvec3& eye) {
    const glm::dvec3 diffuse =
        m::ls_capIrradiance(m::ls_applyDiffuse(toMath(vpl.diffuse), surface.position, surface.normal), vpl.diffuseCap);
    const glm::dvec3 glossy = m::ls_applyGlossy(toMath(vpl.glossy), surface.position, surface.normal,
                                                m::ls_toEye(surface.position, eye), surface.exponent);
    return surface.diffuseAlbedo * diffuse / m::kPi + surface.specular * glossy;
}

glm::dvec3 bruteForce(std::span<const VirtualAreaLight> lights, const Surface& surface, const glm::dvec3& eye,
                      const GatherParameters& parameters) {
    const glm::dvec3 toEye = m::ls_toEye(surface.position, eye);
    const double ck = parameters.cParameter * (surface.exponent + 1.0);
    const glm::dvec3 fs = parameters.glossy ? surface.specular : glm::dvec3(0.0);
    glm::dvec3 sum(0.0);
    for (const VirtualAreaLight& l : lights) {
        const m::GatherSample g =
            m::ls_gatherSample(surface.position, surface.normal, d3(l.position), d3(l.normal), double(l.area),
                               d3(l.flux), toEye, surface.exponent, ck, parameters.epsilonL, parameters.nearField);
        sum += m::ls_bruteForceRadiance(g, surface.diffuseAlbedo, fs);
    }
    return sum;
}

double irradiance(std::span<const VirtualAreaLight> lights, const glm::dvec3& position, const glm::dvec3& normal,
                  int channel, bool nearField) {
    LIGHTSKIN_ASSERT(channel >= 0 && channel < 3, "channel is 0, 1 or 2");
    double sum = 0.0;
    for (const VirtualAreaLight& l : lights) {
        const m::GatherSample g = m::ls_gatherSample(position, normal, d3(l.position), d3(l.normal), double(l.area),
                                                     d3(l.flux), normal, 1.0, 0.0, 0.0, nearField);
        sum += g.irradiance[channel];
    }
    return sum;
}

} // namespace lightskin::gi::reference
