// The GPU techniques stage by stage against two double references for the paper's three setups:
// gi::reference (compiled from the shaders' own lightskin_math.glsl: catches GPU plumbing errors)
// and PaperReference (written separately from the paper: catches formula errors, which the
// shared source would cancel); numerical extremes; invariances (K_cache, sparse-point count, VAL
// resolution); the empty VAL set; the adaptive mode.
//
// Float tolerances (justified): the gather sums ~1e3 terms in float (relative rounding ~1e-6
// per term, sums of positive terms) => 2e-4 relative with a floor of 1e-4 of the largest value
// of that quantity (components near zero are differences of large sums: positions, offsets).
// Renormalised VPLs divide by cos(theta) of the averaged light (amplifies the float error of l'
// where it is near the horizon) => 2e-3. Pixels add the G-buffer position's float error => 3e-3.
#include "GatherTestScenes.h"
#include "GlTestEnvironment.h"
#include "GpuRig.h"
#include "PaperReference.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/BruteForceIllumination.h>
#include <lightskin/gi/LightSkinIllumination.h>
#include <lightskin/gi/LightSkinReference.h>
#include <lightskin/gi/SimpleGBuffer.h>
#include <lightskin/gi/VertexSparsePoints.h>
#include <lightskin/gl/Objects.h>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <string>

namespace lightskin::test {
namespace {

namespace ref = gi::reference;
using glm::dvec3;

struct PaperSetup {
    const char* name;
    bool glossy;
    bool occlusion;
};

/// The shared rig (its own G-buffer and output are not used here: each run makes its own) with
/// the VALs of the scene and a view from above the origin.
struct Scene : GpuRig {
    std::vector<gi::VirtualAreaLight> vals;
    Scene() {
        eye = {2.0f, -2.0f, 2.0f};
        target = glm::vec3(0.0f);
    }
};

std::vector<glm::vec4> readTexels(const gl::Texture& texture) {
    std::vector<glm::vec4> texels(std::size_t(texture.width()) * std::size_t(texture.height()));
    glGetTextureImage(texture.id(), 0, GL_RGBA, GL_FLOAT, GLsizei(texels.size() * sizeof(glm::vec4)), texels.data());
    return texels;
}

struct GpuRun {
    std::vector<glm::vec4> image, gbufferPosition, gbufferNormal, gather, vpls, occlusion, vertex;
    std::vector<gl::StageTime> times;
};

gl::Buffer uploadVals(const std::vector<gi::VirtualAreaLight>& vals) {
    return gl::Buffer::create(GLsizeiptr(std::max<std::size_t>(vals.size(), 1) * sizeof(gi::VirtualAreaLight)),
                              vals.empty() ? nullptr : vals.data(), 0);
}

GpuRun runLightSkin(Scene& scene, const gi::LightSkinSettings& settings, gi::LightSkinChoice* choice = nullptr) {
    scene.upload();
    auto technique = gi::LightSkinIllumination::create(settings, scene.provider());
    technique->prepare(scene.instances);
    gi::SimpleGBuffer gbuffer = gi::SimpleGBuffer::create(scene.width, scene.height);
    const gi::ViewParameters view = scene.view();
    gbuffer.render(scene.instances, view.clip_T_world);
    gl::Texture target = gl::Texture::create2D(GL_RGBA32F, scene.width, scene.height);
    const gl::Buffer vals = uploadVals(scene.vals);
    GpuRun run;
    technique->render({vals.id(), std::uint32_t(scene.vals.size())}, scene.instances, gbuffer.view(), view,
                      target.id());
    run.image = readTexels(target);
    run.gbufferPosition = readTexels(gbuffer.position());
    run.gbufferNormal = readTexels(gbuffer.normal());
    technique->readGatherSums(run.gather);
    technique->readSparseVpls(run.vpls);
    technique->readOcclusion(run.occlusion);
    technique->readVertexVpls(run.vertex);
    technique->lastStageTimes(run.times);
    if (choice) *choice = technique->lastChoice();
    return run;
}

GpuRun runBruteForce(Scene& scene, bool glossy) {
    scene.upload();
    gi::BruteForceSettings settings;
    settings.glossy = glossy;
    auto technique = gi::BruteForceIllumination::create(settings);
    technique->prepare(scene.instances);
    gi::SimpleGBuffer gbuffer = gi::SimpleGBuffer::create(scene.width, scene.height);
    const gi::ViewParameters view = scene.view();
    gbuffer.render(scene.instances, view.clip_T_world);
    gl::Texture target = gl::Texture::create2D(GL_RGBA32F, scene.width, scene.height);
    const gl::Buffer vals = uploadVals(scene.vals);
    technique->render({vals.id(), std::uint32_t(scene.vals.size())}, scene.instances, gbuffer.view(), view,
                      target.id());
    GpuRun run;
    run.image = readTexels(target);
    run.gbufferPosition = readTexels(gbuffer.position());
    run.gbufferNormal = readTexels(gbuffer.normal());
    return run;
}

// The reference pipeline on the same scene.
struct ReferenceRun {
    std::vector<ref::Receiver> receivers;
    std::vector<ref::GatherSums> sums;
    std::vector<ref::VplPair> vpls, occluded, vertex;
    std::vector<glm::dvec2> occlusion;
    std::vector<dvec3> vertexPositions, vertexNormals;
    std::vector<std::array<std::uint32_t, 3>> triangles; // global vertex indices
    std::vector<const gi::MeshInstance*> triangleInstance;
    std::vector<std::array<std::uint32_t, 8>> neighbours; // global sparse-point indices per vertex
    bool independent = false;                             // from PaperReference (pixels shaded with paper::shade too)
};

ReferenceRun runReference(const Scene& scene, const PaperSetup& setup) {
    ReferenceRun r;
    ref::GatherParameters parameters;
    parameters.glossy = setup.glossy;
    std::vector<std::array<std::uint32_t, 8>>& neighbours = r.neighbours;
    for (std::size_t m = 0; m < scene.meshes.size(); ++m) {
        const TriangleMesh& mesh = scene.meshes[m];
        const gi::SparsePointSet set = scene.sparsePoints(m);
        const auto offset = std::uint32_t(r.receivers.size());
        const auto vertexOffset = std::uint32_t(r.vertexPositions.size());
        const auto receivers = ref::receiversFromSparsePoints(
            set, scene.instances[m].world_T_model, std::max(1.0, double(scene.instances[m].material.specularExponent)));
        r.receivers.insert(r.receivers.end(), receivers.begin(), receivers.end());
        const glm::dmat4 transform(scene.instances[m].world_T_model);
        const glm::dmat3 normalMatrix = glm::transpose(glm::inverse(glm::dmat3(transform)));
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
            r.vertexPositions.push_back(dvec3(transform * glm::dvec4(dvec3(mesh.positions[v]), 1.0)));
            r.vertexNormals.push_back(glm::normalize(normalMatrix * dvec3(mesh.normals[v])));
            auto list = set.vertexNeighbours[v];
            for (auto& index : list) index += offset;
            neighbours.push_back(list);
        }
        for (std::size_t t = 0; t < mesh.indices.size(); t += 3) {
            r.triangles.push_back({mesh.indices[t] + vertexOffset, mesh.indices[t + 1] + vertexOffset,
                                   mesh.indices[t + 2] + vertexOffset});
            r.triangleInstance.push_back(&scene.instances[m]);
        }
    }
    const dvec3 eye(scene.eye);
    ref::gatherInto(scene.vals, r.receivers, eye, parameters, r.sums);
    ref::renormaliseInto(r.sums, r.receivers, eye, r.vpls);
    r.occluded = r.vpls;
    r.occlusion.assign(r.receivers.size(), glm::dvec2(0.0));
    if (setup.occlusion) {
        ref::occlusionInto(r.receivers, r.vpls, r.occlusion);
        ref::applyOcclusion(r.occlusion, r.occluded);
    }
    ref::interpolateVerticesInto(r.vertexPositions, r.vertexNormals, neighbours, r.receivers, r.occluded, r.vertex);
    return r;
}

/// The same run from PaperReference (independent formulas), in gi::reference's sum layout so
/// that compareStages() checks the GPU against it: offsets (l' - x) W, r^2 sums rbar^2 W,
/// moments (sigma^2 + (l' - x)^2) W per axis (diffuse) and summed (glossy).
ReferenceRun runIndependent(const Scene& scene, const PaperSetup& setup, const ReferenceRun& shared) {
    ReferenceRun r = shared;
    r.independent = true;
    std::vector<paper::Point> points;
    for (const ref::Receiver& x : r.receivers) points.push_back({x.position, x.normal, x.exponent, x.occluderRadius});
    paper::Options options;
    options.glossy = setup.glossy;
    const paper::Run run = paper::run(scene.vals, points, dvec3(scene.eye), options, setup.occlusion);
    for (std::size_t i = 0; i < points.size(); ++i) {
        const dvec3 x = points[i].position;
        const paper::Averaged& d = run.gathers[i].diffuse;
        const paper::Averaged& g = run.gathers[i].glossy;
        ref::GatherSums& s = r.sums[i];
        const dvec3 offD = d.weight > 0.0 ? d.position - x : dvec3(0.0);
        const dvec3 offS = g.weight > 0.0 ? g.position - x : dvec3(0.0);
        s.irradiance = d.sum;
        s.weightD = d.weight;
        s.offsetD = offD * d.weight;
        s.r2D = d.meanR2 * d.weight;
        s.momentD = (d.variance + offD * offD) * d.weight;
        s.glossy = g.sum;
        s.weightS = g.weight;
        s.offsetS = offS * g.weight;
        s.r2S = g.meanR2 * g.weight;
        s.momentS = (g.variance.x + g.variance.y + g.variance.z + glm::dot(offS, offS)) * g.weight;
        const auto toVpl = [](const paper::Light& l) { return ref::Vpl{l.radiance, l.r2, l.position, l.sphereRadius}; };
        r.vpls[i] = {toVpl(run.lights[i].diffuse), toVpl(run.lights[i].glossy)};
        r.occluded[i] = {toVpl(run.occluded[i].diffuse), toVpl(run.occluded[i].glossy)};
        r.occlusion[i] = run.occlusion[i];
    }
    for (std::size_t v = 0; v < r.vertexPositions.size(); ++v) {
        const paper::LightPair p =
            paper::interpolate(r.vertexPositions[v], r.vertexNormals[v], r.neighbours[v], points, run.occluded);
        r.vertex[v].diffuse = {p.diffuse.radiance, p.diffuse.r2, p.diffuse.position, 0.0};
        r.vertex[v].glossy = {p.glossy.radiance, p.glossy.r2, p.glossy.position, 0.0};
    }
    return r;
}

/// Occlusion is discontinuous where S_o degenerates to a point (one VAL dominates a channel): guard
/// G7 gives o = 0 for a radius of exactly 0, while any radius > 0 inside an occluder's quad gives
/// o = 1. The GPU computes the radius from float moment sums (asserted to 1e-3 of the largest
/// radius, compareStages), so below that it cannot tell 0 from a tiny radius. At those points
/// (channel by channel) the reference adopts the GPU's o and recomputes the occluded VPLs and the
/// vertices, so later stages are still compared; returns how many (point, channel) pairs.
std::size_t adoptUnresolvedOcclusion(ReferenceRun& r, const GpuRun& gpu) {
    double largestD = 0.0, largestS = 0.0;
    for (const ref::VplPair& v : r.vpls) {
        largestD = std::max(largestD, v.diffuse.sphereRadius);
        largestS = std::max(largestS, v.glossy.sphereRadius);
    }
    std::size_t adopted = 0;
    for (std::size_t i = 0; i < r.vpls.size(); ++i) {
        const glm::dvec2 o = glm::clamp(glm::dvec2(gpu.occlusion[i]), 0.0, 1.0);
        if (r.vpls[i].diffuse.sphereRadius <= 1e-3 * largestD && o.x != r.occlusion[i].x) {
            r.occlusion[i].x = o.x;
            ++adopted;
        }
        if (r.vpls[i].glossy.sphereRadius <= 1e-3 * largestS && o.y != r.occlusion[i].y) {
            r.occlusion[i].y = o.y;
            ++adopted;
        }
        r.occluded[i] = r.vpls[i];
        r.occluded[i].diffuse.radiance *= 1.0 - r.occlusion[i].x;
        r.occluded[i].glossy.radiance *= 1.0 - r.occlusion[i].y;
    }
    if (adopted == 0) return 0;
    if (!r.independent) {
        ref::interpolateVerticesInto(r.vertexPositions, r.vertexNormals, r.neighbours, r.receivers, r.occluded,
                                     r.vertex);
        return adopted;
    }
    std::vector<paper::Point> points;
    std::vector<paper::LightPair> lights;
    for (std::size_t i = 0; i < r.receivers.size(); ++i) {
        const ref::Receiver& x = r.receivers[i];
        points.push_back({x.position, x.normal, x.exponent, x.occluderRadius});
        const ref::VplPair& v = r.occluded[i];
        lights.push_back({{v.diffuse.radiance, v.diffuse.position, v.diffuse.r2, v.diffuse.sphereRadius},
                          {v.glossy.radiance, v.glossy.position, v.glossy.r2, v.glossy.sphereRadius}});
    }
    for (std::size_t v = 0; v < r.vertexPositions.size(); ++v) {
        const paper::LightPair p =
            paper::interpolate(r.vertexPositions[v], r.vertexNormals[v], r.neighbours[v], points, lights);
        r.vertex[v].diffuse = {p.diffuse.radiance, p.diffuse.r2, p.diffuse.position, 0.0};
        r.vertex[v].glossy = {p.glossy.radiance, p.glossy.r2, p.glossy.position, 0.0};
    }
    return adopted;
}

/// Per-pixel reference: the triangle under the G-buffer position, barycentric interpolation of
/// the reference vertex VPLs (what the rasteriser does, perspective-correct), eq. 10.
std::optional<dvec3> referencePixel(const ReferenceRun& r, const dvec3& p, const dvec3& n, const dvec3& eye,
                                    bool glossy) {
    double best = 1e300;
    std::optional<dvec3> result;
    for (std::size_t t = 0; t < r.triangles.size(); ++t) {
        const dvec3 a = r.vertexPositions[r.triangles[t][0]], b = r.vertexPositions[r.triangles[t][1]],
                    c = r.vertexPositions[r.triangles[t][2]];
        const dvec3 normal = glm::cross(b - a, c - a);
        const double area2 = glm::dot(normal, normal);
        if (area2 <= 0.0) continue;
        const double distance = std::abs(glm::dot(p - a, normal)) / std::sqrt(area2);
        if (distance >= best) continue;
        const double wa = glm::dot(glm::cross(c - b, p - b), normal) / area2;
        const double wb = glm::dot(glm::cross(a - c, p - c), normal) / area2;
        const double wc = 1.0 - wa - wb;
        const double eps = -1e-4;
        if (wa < eps || wb < eps || wc < eps) continue;
        best = distance;
        ref::VplPair v{};
        const double w[3] = {wa, wb, wc};
        for (int k = 0; k < 3; ++k) {
            const ref::VplPair& s = r.vertex[r.triangles[t][std::size_t(k)]];
            v.diffuse.radiance += w[k] * s.diffuse.radiance;
            v.diffuse.r2 += w[k] * s.diffuse.r2;
            v.diffuse.position += w[k] * s.diffuse.position;
            v.glossy.radiance += w[k] * s.glossy.radiance;
            v.glossy.r2 += w[k] * s.glossy.r2;
            v.glossy.position += w[k] * s.glossy.position;
        }
        const Material& material = r.triangleInstance[t]->material;
        const ref::Surface surface{p, n, dvec3(material.diffuseAlbedo),
                                   glossy ? dvec3(material.specularAlbedo) : dvec3(0.0),
                                   double(material.specularExponent)};
        if (r.independent) {
            const paper::LightPair l{{v.diffuse.radiance, v.diffuse.position, v.diffuse.r2, 0.0},
                                     {v.glossy.radiance, v.glossy.position, v.glossy.r2, 0.0}};
            result = paper::shade(l, p, n, eye, surface.diffuseAlbedo, surface.specular, surface.exponent);
        } else {
            result = ref::shade(v, surface, eye);
        }
    }
    return result;
}

/// |gpu - ref| <= rel |ref| + floorFraction * max|ref| for every listed value; reports the worst.
class Comparison {
public:
    Comparison(const char* what, double rel, double floorFraction, double absolute = 0.0)
        : what_(what)
        , rel_(rel)
        , floor_(floorFraction)
        , absolute_(absolute) {}
    void add(double gpu, double reference) { pairs_.emplace_back(gpu, reference); }
    void check() const {
        double largest = 0.0;
        for (const auto& [g, r] : pairs_) largest = std::max(largest, std::abs(r));
        std::size_t bad = 0;
        double worst = 0.0;
        for (const auto& [g, r] : pairs_) {
            ASSERT_TRUE(std::isfinite(g)) << what_;
            const double tolerance = rel_ * std::abs(r) + floor_ * largest + absolute_ + 1e-30;
            worst = std::max(worst, std::abs(g - r) / tolerance);
            if (std::abs(g - r) > tolerance) {
                if (bad < 4 && std::getenv("LIGHTSKIN_TEST_VERBOSE"))
                    std::printf("%s: gpu %.9g ref %.9g\n", what_, g, r);
                ++bad;
            }
        }
        EXPECT_EQ(bad, 0u) << what_ << ": " << bad << " of " << pairs_.size()
                           << " values outside tolerance; worst error / tolerance = " << worst;
    }

private:
    const char* what_;
    double rel_, floor_, absolute_;
    std::vector<std::pair<double, double>> pairs_;
};

void compareStages(const GpuRun& gpu, const ReferenceRun& r, const PaperSetup& setup) {
    const std::size_t n = r.receivers.size();
    ASSERT_EQ(gpu.gather.size(), 5 * n);
    // cos^k amplifies the float error of cos(gamma) (~2.4e-7 relative) k times.
    double maxExponent = 1.0, sceneExtent = 0.0;
    for (const ref::Receiver& x : r.receivers) {
        maxExponent = std::max(maxExponent, x.exponent);
        sceneExtent = std::max(sceneExtent, glm::length(x.position));
    }
    // positions carry the float rounding of world coordinates (6e-8 of the scene's extent)
    const double positionFloor = 1e-6 * sceneExtent;
    const double glossyRel = 2e-4 + 2.4e-7 * maxExponent;
    // One comparator per quantity and channel: the floor is a fraction of that quantity's own
    // largest value (pooling W with sum r^2 w, ~1e3 times smaller, made the floor ~10 % of the
    // latter).
    Comparison irradiance("L'_d", 2e-4, 1e-4), glossy("L'_s", glossyRel, 1e-4), weightD("W_d", 2e-4, 1e-4),
        weightS("W_s", glossyRel, 1e-4), r2D("sum r^2 w_d", 2e-4, 1e-4), r2S("sum r^2 w_s", glossyRel, 1e-4),
        offsetD("sum (l - x) w_d", 2e-4, 1e-4), offsetS("sum (l - x) w_s", glossyRel, 1e-4),
        momentD("sum (l - x)^2 w_d", 2e-4, 1e-4), momentS("sum |l - x|^2 w_s", glossyRel, 1e-4);
    for (std::size_t i = 0; i < n; ++i) {
        const ref::GatherSums& s = r.sums[i];
        const glm::vec4* g = &gpu.gather[5 * i];
        for (int c = 0; c < 3; ++c) {
            irradiance.add(g[0][c], s.irradiance[c]);
            offsetD.add(g[1][c], s.offsetD[c]);
            glossy.add(g[2][c], s.glossy[c]);
            offsetS.add(g[3][c], s.offsetS[c]);
            if (setup.occlusion) momentD.add(g[4][c], s.momentD[c]);
        }
        weightD.add(g[1].w, s.weightD);
        weightS.add(g[3].w, s.weightS);
        r2D.add(g[0].w, s.r2D);
        r2S.add(g[2].w, s.r2S);
        if (setup.occlusion && setup.glossy) momentS.add(g[4].w, s.momentS);
    }
    for (const Comparison* c : {&irradiance, &weightD, &r2D, &offsetD}) c->check();
    if (setup.glossy)
        for (const Comparison* c : {&glossy, &weightS, &r2S, &offsetS}) c->check();
    if (setup.occlusion) momentD.check();
    if (setup.occlusion && setup.glossy) momentS.check();

    // rbar^2 is a ratio of two gathered sums (2 x 2e-4); the S_o radius is the square root of a
    // difference of moments (cancellation: 1e-3 of the largest radius as floor).
    const double vplRel = 2e-3 + 2.4e-7 * maxExponent;
    Comparison radianceD("L''_d", 2e-3, 1e-4), radianceS("L''_s", vplRel, 1e-4), meanR2D("rbar^2_d", 4e-4, 1e-4),
        meanR2S("rbar^2_s", 2.0 * glossyRel, 1e-4), positionD("l'_d", 0.0, 1e-4, positionFloor),
        positionS("l'_s", 0.0, 1e-4, positionFloor), sphereD("S_o radius (diffuse)", 2e-3, 1e-3),
        sphereS("S_o radius (glossy)", 2e-3, 1e-3);
    for (std::size_t i = 0; i < n; ++i) {
        const glm::vec4* v = &gpu.vpls[4 * i];
        for (int c = 0; c < 3; ++c) {
            radianceD.add(v[0][c], r.vpls[i].diffuse.radiance[c]);
            radianceS.add(v[2][c], r.vpls[i].glossy.radiance[c]);
            positionD.add(v[1][c], r.vpls[i].diffuse.position[c]);
            positionS.add(v[3][c], r.vpls[i].glossy.position[c]);
        }
        meanR2D.add(v[0].w, r.vpls[i].diffuse.r2);
        meanR2S.add(v[2].w, r.vpls[i].glossy.r2);
        sphereD.add(v[1].w, r.vpls[i].diffuse.sphereRadius);
        sphereS.add(v[3].w, r.vpls[i].glossy.sphereRadius);
    }
    for (const Comparison* c : {&radianceD, &meanR2D, &positionD}) c->check();
    if (setup.glossy)
        for (const Comparison* c : {&radianceS, &meanR2S, &positionS}) c->check();
    if (setup.occlusion) sphereD.check();
    if (setup.occlusion && setup.glossy) sphereS.check();

    if (setup.occlusion) {
        // o sums overlap terms computed from the stage above (l', S_o radius within 2e-3
        // relative): each term moves by <= its own value times that, so 2e-3 absolute on o in [0, 1]
        Comparison occlusionD("o_d", 0.0, 0.0, 2e-3), occlusionS("o_s", 0.0, 0.0, 2e-3);
        for (std::size_t i = 0; i < n; ++i) {
            occlusionD.add(std::clamp(double(gpu.occlusion[i].x), 0.0, 1.0), r.occlusion[i].x);
            if (setup.glossy) occlusionS.add(std::clamp(double(gpu.occlusion[i].y), 0.0, 1.0), r.occlusion[i].y);
        }
        occlusionD.check();
        if (setup.glossy) occlusionS.check();
    }

    // eq. 13 averages the VPLs above with normalised weights: the same relative bounds, plus the
    // float weights (8 terms, ~1e-6) => 3e-3
    Comparison vertexD("vertex L'''_d", 3e-3, 1e-4), vertexS("vertex L'''_s", 3e-3 + 2.4e-7 * maxExponent, 1e-4),
        vertexR2D("vertex rbar^2_d", 1e-3, 1e-4), vertexR2S("vertex rbar^2_s", 1e-3 + 2.0 * glossyRel, 1e-4),
        vertexPositionD("vertex l'''_d", 0.0, 1e-4, positionFloor),
        vertexPositionS("vertex l'''_s", 0.0, 1e-4, positionFloor);
    ASSERT_EQ(gpu.vertex.size(), 4 * r.vertex.size());
    for (std::size_t v = 0; v < r.vertex.size(); ++v) {
        const glm::vec4* g = &gpu.vertex[4 * v];
        for (int c = 0; c < 3; ++c) {
            vertexD.add(g[0][c], r.vertex[v].diffuse.radiance[c]);
            vertexS.add(g[2][c], r.vertex[v].glossy.radiance[c]);
            vertexPositionD.add(g[1][c], r.vertex[v].diffuse.position[c]);
            vertexPositionS.add(g[3][c], r.vertex[v].glossy.position[c]);
        }
        vertexR2D.add(g[0].w, r.vertex[v].diffuse.r2);
        vertexR2S.add(g[2].w, r.vertex[v].glossy.r2);
    }
    for (const Comparison* c : {&vertexD, &vertexR2D, &vertexPositionD}) c->check();
    if (setup.glossy)
        for (const Comparison* c : {&vertexS, &vertexR2S, &vertexPositionS}) c->check();
}

void comparePixels(const GpuRun& gpu, const ReferenceRun& r, const Scene& scene, bool glossy, double rel) {
    Comparison pixels("pixel radiance", rel, 1e-3);
    std::size_t covered = 0;
    for (std::size_t i = 0; i < gpu.image.size(); ++i) {
        if (gpu.gbufferPosition[i].w == 0.0f) {
            EXPECT_EQ(gpu.image[i], glm::vec4(0.0f)) << "uncovered pixels must be 0";
            continue;
        }
        const auto expected = referencePixel(r, dvec3(gpu.gbufferPosition[i]),
                                             glm::normalize(dvec3(gpu.gbufferNormal[i])), dvec3(scene.eye), glossy);
        if (!expected) continue;
        ++covered;
        for (int c = 0; c < 3; ++c) {
            EXPECT_GE(gpu.image[i][c], 0.0f);
            pixels.add(gpu.image[i][c], (*expected)[c]);
        }
    }
    EXPECT_GT(covered, gpu.image.size() / 10);
    pixels.check();
}

Scene sphereOverFloor() {
    Scene scene;
    Material sphereMaterial;
    sphereMaterial.diffuseAlbedo = {0.8f, 0.7f, 0.6f};
    sphereMaterial.specularAlbedo = {0.3f, 0.3f, 0.3f};
    sphereMaterial.specularExponent = 20.0f;
    // rotated about its centre (same surface): model and world normals differ, so a missing
    // normal transform in any stage shows
    scene.add(
        makeSphere(0.3f, 12, 24),
        glm::rotate(glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 0.45f}), 0.7f, glm::normalize(glm::vec3(1, 2, 3))),
        sphereMaterial, 120);
    Material floorMaterial;
    floorMaterial.diffuseAlbedo = {0.5f, 0.5f, 0.5f};
    floorMaterial.specularAlbedo = {0.2f, 0.1f, 0.0f};
    floorMaterial.specularExponent = 5.0f;
    scene.add(makeGrid(2.0f, 12), glm::mat4(1.0f), floorMaterial, 60);
    scene.vals = squareEmitter({-1.0f, 0.0f, 0.6f}, {1.0f, 0.0f, 0.0f}, 1.2f, 24, {1.0f, 0.8f, 0.6f});
    const auto extra = randomVals(424, {-1.5f, -1.5f, 1.0f}, {1.5f, 1.5f, 2.0f}, {0, 0, 0}, 0.005f, 11);
    scene.vals.insert(scene.vals.end(), extra.begin(), extra.end());
    scene.eye = {1.6f, -1.8f, 1.5f};
    scene.target = {0.0f, 0.0f, 0.3f};
    return scene;
}

class LightSkinSetupGLTest : public GlTest, public ::testing::WithParamInterface<PaperSetup> {};

TEST_P(LightSkinSetupGLTest, EveryStageMatchesBothDoubleReferences) {
    const PaperSetup setup = GetParam();
    Scene scene = sphereOverFloor();
    scene.productionSampler = true;
    gi::LightSkinSettings settings;
    settings.glossy = setup.glossy;
    settings.occlusion = setup.occlusion;
    const GpuRun gpu = runLightSkin(scene, settings);
    ReferenceRun shared = runReference(scene, setup);
    ReferenceRun independent = runIndependent(scene, setup, shared);
    for (ReferenceRun* r : {&shared, &independent}) {
        // a scene where many points had a point-like S_o would not test occlusion: at most 2 %
        const std::size_t adopted = setup.occlusion ? adoptUnresolvedOcclusion(*r, gpu) : 0;
        EXPECT_LE(adopted, r->receivers.size() / 50) << "points with an unresolved, point-like S_o";
        SCOPED_TRACE(r->independent ? "against PaperReference (independent formulas)"
                                    : "against gi::reference (the shaders' own math in double)");
        compareStages(gpu, *r, setup);
        comparePixels(gpu, *r, scene, setup.glossy, 3e-3);
    }
    // the stages compared must carry signal: light in every channel the setup has, occlusion
    double maxIrradiance = 0.0, maxGlossy = 0.0, maxOcclusionD = 0.0, maxOcclusionS = 0.0;
    for (std::size_t i = 0; i < independent.receivers.size(); ++i) {
        maxIrradiance = std::max(maxIrradiance, independent.sums[i].irradiance.x);
        maxGlossy = std::max(maxGlossy, independent.sums[i].glossy.x);
        maxOcclusionD = std::max(maxOcclusionD, independent.occlusion[i].x);
        maxOcclusionS = std::max(maxOcclusionS, independent.occlusion[i].y);
    }
    EXPECT_GT(maxIrradiance, 0.1);
    if (setup.glossy) {
        EXPECT_GT(maxGlossy, 0.01);
    }
    if (setup.occlusion) {
        EXPECT_GT(maxOcclusionD, 0.05) << "the scene must exercise occlusion (floor under the sphere)";
        EXPECT_GT(maxOcclusionS, 0.05) << "and glossy occlusion";
    }
}

INSTANTIATE_TEST_SUITE_P(PaperSetups, LightSkinSetupGLTest,
                         ::testing::Values(PaperSetup{"diffuse", false, false}, PaperSetup{"glossy", true, false},
                                           PaperSetup{"occlusion", true, true}),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

using BruteForceGLTest = GlTest;

TEST_F(BruteForceGLTest, MatchesTheDoubleReferenceAtEveryPixel) {
    for (const bool glossy : {true, false}) {
        Scene scene = sphereOverFloor();
        const GpuRun gpu = runBruteForce(scene, glossy);
        ref::GatherParameters parameters;
        parameters.glossy = glossy;
        Comparison pixels(glossy ? "brute-force pixel (glossy)" : "brute-force pixel (diffuse)", 2e-4, 1e-4);
        for (std::size_t i = 0; i < gpu.image.size(); ++i) {
            if (gpu.gbufferPosition[i].w == 0.0f) {
                EXPECT_EQ(gpu.image[i], glm::vec4(0.0f));
                continue;
            }
            // which instance: the floor is the plane z = 0
            const bool floor = std::abs(gpu.gbufferPosition[i].z) < 1e-4f;
            const Material& m = scene.instances[floor ? 1 : 0].material;
            const ref::Surface s{dvec3(gpu.gbufferPosition[i]), glm::normalize(dvec3(gpu.gbufferNormal[i])),
                                 dvec3(m.diffuseAlbedo), dvec3(m.specularAlbedo), double(m.specularExponent)};
            const dvec3 expected = ref::bruteForce(scene.vals, s, dvec3(scene.eye), parameters);
            for (int c = 0; c < 3; ++c) pixels.add(gpu.image[i][c], expected[c]);
        }
        pixels.check();
    }
}

TEST_F(BruteForceGLTest, LightSkinIsCloseToBruteForceOnASmoothScene) {
    // Diffuse setup on one sphere lit by a large emitter: interpolation error only.
    Scene scene;
    Material material;
    scene.add(makeSphere(0.4f, 16, 32), glm::mat4(1.0f), material, 200);
    scene.vals = squareEmitter({0.0f, 0.0f, 1.5f}, {0.2f, 0.1f, -1.0f}, 2.0f, 24, {1.0f, 1.0f, 1.0f});
    gi::LightSkinSettings settings;
    settings.glossy = false;
    settings.occlusion = false;
    const GpuRun lightskin = runLightSkin(scene, settings);
    const GpuRun brute = runBruteForce(scene, false);
    double sumL = 0.0, sumB = 0.0, sumAbs = 0.0;
    for (std::size_t i = 0; i < brute.image.size(); ++i) {
        sumL += double(lightskin.image[i].x);
        sumB += double(brute.image[i].x);
        sumAbs += double(std::abs(lightskin.image[i].x - brute.image[i].x));
    }
    ASSERT_GT(sumB, 0.0);
    EXPECT_NEAR(sumL / sumB, 1.0, 0.03);
    EXPECT_LT(sumAbs / sumB, 0.05) << "mean absolute per-pixel error relative to the mean";
}

// ---- analytic results through the GPU gather -------------------------------------------------
using LightSkinAnalyticGLTest = GlTest;

TEST_F(LightSkinAnalyticGLTest, CoaxialDiscAndLargeUniformPlaneOnTheGpu) {
    Scene scene;
    Material material;
    scene.add(makeGrid(0.2f, 4), glm::mat4(1.0f), material, 25);
    const float radiance = 0.7f, h = 1.0f;
    auto centreIrradiance = [&](const std::vector<gi::VirtualAreaLight>& vals) {
        scene.vals = vals;
        scene.upload();
        auto technique = gi::LightSkinIllumination::create({}, scene.provider());
        technique->prepare(scene.instances);
        gi::SimpleGBuffer gbuffer = gi::SimpleGBuffer::create(8, 8);
        gl::Texture target = gl::Texture::create2D(GL_RGBA32F, 8, 8);
        const gl::Buffer buffer = uploadVals(scene.vals);
        technique->render({buffer.id(), std::uint32_t(vals.size())}, scene.instances, gbuffer.view(), scene.view(),
                          target.id());
        std::vector<glm::vec4> sums;
        technique->readGatherSums(sums);
        const auto& points = technique->sparsePoints()[0].points;
        for (std::size_t i = 0; i < points.size(); ++i)
            if (glm::length(points[i].position) < 1e-6f) return double(sums[5 * i].x);
        ADD_FAILURE() << "no sparse point at the centre";
        return 0.0;
    };
    // a single coaxial disc: E = M r^2 / (r^2 + h^2) exactly (float rounding only)
    const float area = 0.3f;
    const double m = double(radiance) * std::numbers::pi;
    const double r2 = double(area) / std::numbers::pi;
    const double disc1 = centreIrradiance({disc({0, 0, h}, {0, 0, -1}, area, glm::vec3(float(m) * area))});
    EXPECT_NEAR(disc1, m * r2 / (r2 + double(h * h)), 1e-6 * m);
    // a large uniform plane (40 x 40 h, 160k VALs): E -> pi L (finite-size and disc
    // discretisation errors < 0.5 %, see GatherReference.LargeUniformPlaneGivesPiTimesRadiance)
    const double plane = centreIrradiance(squareEmitter({0, 0, h}, {0, 0, -1}, 40.0f, 400, glm::vec3(radiance)));
    EXPECT_NEAR(plane / m, 1.0, 5e-3);
    // 10^6 VALs (7813 chunked passes): a 1 x 1 square at h = 0.5, exact form factor
    // (4/pi) X/sqrt(1+X^2) atan(X/sqrt(1+X^2)), X = 1; float sums of 10^6 terms stay within 1e-4
    const auto million = squareEmitter({0, 0, 0.5f}, {0, 0, -1}, 1.0f, 1000, glm::vec3(radiance));
    ASSERT_EQ(million.size(), 1000000u);
    const double q = std::sqrt(2.0);
    const double exact = 4.0 / std::numbers::pi / q * std::atan(1.0 / q);
    EXPECT_NEAR(centreIrradiance(million) / m, exact, 2e-4);
}

/// A flat disc fan: vertex 0 at the centre, `ring` vertices at `radius`, all normals `normal`
/// (z = +1 or -1). sparsePointsFromVertices(mesh, 1) puts its one point at the centre with
/// occluder radius `radius` (the farthest vertex of its Voronoi region).
TriangleMesh discFan(float radius, float normalZ, int ring = 16) {
    TriangleMesh mesh;
    mesh.positions.emplace_back(0.0f);
    for (int i = 0; i < ring; ++i) {
        const float phi = 2.0f * std::numbers::pi_v<float> * float(i) / float(ring);
        mesh.positions.emplace_back(radius * std::cos(phi), radius * std::sin(phi), 0.0f);
    }
    mesh.normals.assign(mesh.positions.size(), glm::vec3(0.0f, 0.0f, normalZ));
    for (int i = 0; i < ring; ++i) {
        const auto a = std::uint32_t(1 + i), b = std::uint32_t(1 + (i + 1) % ring);
        if (normalZ > 0.0f)
            mesh.indices.insert(mesh.indices.end(), {0u, a, b});
        else
            mesh.indices.insert(mesh.indices.end(), {0u, b, a});
    }
    return mesh;
}

// eq. 14 / section 3.3 through the GPU with a closed form (as PaperReference's unit test): a
// sparse point at the origin facing up, two equal VALs at (+-a, 0, D) facing down (so l' = (0, 0,
// D), the diffuse S_o radius is sigma_x = a and the glossy one sqrt(a^2 / 3); the eye is on the
// symmetry plane x = 0, so both VALs weigh the same in both channels) and one occluder disc of
// radius r at height d facing down. Both project to concentric circles on the unit circle
// (Nusselt), so o = F_occ / F_S with F = r^2 / (r^2 + d^2) (eq. 3, cos = 1) while F_occ < F_S.
// Float: each o is ~20 float operations from exact inputs (~1e-6); 1e-4 absolute.
TEST_F(LightSkinAnalyticGLTest, OneCoaxialOccluderDiscHidesTheAnalyticFractionOnTheGpu) {
    const float a = 0.4f, height = 2.0f, r = 0.04f, d = 0.5f;
    Scene scene;
    Material material;
    material.specularAlbedo = glm::vec3(0.3f);
    material.specularExponent = 2.0f;
    scene.add(discFan(0.01f, 1.0f), glm::mat4(1.0f), material, 1);
    scene.add(discFan(r, -1.0f), glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, d}), material, 1);
    scene.vals = {disc({a, 0, height}, {0, 0, -1}, 0.01f, {0.1f, 0.1f, 0.1f}),
                  disc({-a, 0, height}, {0, 0, -1}, 0.01f, {0.1f, 0.1f, 0.1f})};
    scene.eye = {0.0f, 1.0f, 5.0f};
    scene.target = {0.0f, 0.0f, 0.0f};
    const GpuRun run = runLightSkin(scene, {});
    ASSERT_FALSE(run.occlusion.empty());
    const auto f = [](double radius, double distance) {
        return radius * radius / (radius * radius + distance * distance);
    };
    const double ad = double(a), hd = double(height);
    const double expectedD = f(double(r), double(d)) / f(ad, hd);
    const double expectedS = f(double(r), double(d)) / f(ad / std::sqrt(3.0), hd);
    ASSERT_LT(expectedS, 1.0) << "the occluder must hide only part of both targets";
    EXPECT_NEAR(double(run.vpls[1].w), ad, 1e-4) << "diffuse S_o radius";
    EXPECT_NEAR(double(run.vpls[3].w), ad / std::sqrt(3.0), 1e-4) << "glossy S_o radius";
    EXPECT_NEAR(double(run.occlusion[0].x), expectedD, 1e-4);
    EXPECT_NEAR(double(run.occlusion[0].y), expectedS, 1e-4);
}

// ---- numerical extremes on the GPU -------------------------------------------------------
struct GpuExtreme {
    const char* name;
    float scale = 1.0f;
    float exponent = 20.0f;
    std::vector<gi::VirtualAreaLight> (*vals)(float scale);
};

std::vector<gi::VirtualAreaLight> valsCoincident(float) { return {disc({0, 0, 0}, {0, 0, -1}, 1e-3f, {1, 1, 1})}; }
std::vector<gi::VirtualAreaLight> valsMicron(float) { return {disc({0, 0, 1e-6f}, {0, 0, -1}, 1e-3f, {1, 1, 1})}; }
std::vector<gi::VirtualAreaLight> valsPlane(float s) {
    return squareEmitter({0.2f * s, 0.0f, 0.6f * s}, {0.1f, 0.2f, -1.0f}, s, 12, {1.0f, 0.5f, 0.25f});
}
std::vector<gi::VirtualAreaLight> valsGrazing(float) {
    return {disc({0.8f, 0.0f, 1e-3f}, {-1, 0, 0}, 1e-2f, {1, 1, 1}),
            disc({-0.8f, 0.0f, -1e-3f}, {1, 0, 0}, 1e-2f, {1, 1, 1}),
            disc({0.0f, 0.8f, 0.0f}, {0, -1, 0.001f}, 1e-2f, {1, 1, 1})};
}
std::vector<gi::VirtualAreaLight> valsBackFacing(float) {
    return squareEmitter({0, 0, 0.5f}, {0, 0, 1}, 1.0f, 8, {1, 1, 1});
}
std::vector<gi::VirtualAreaLight> valsSingle(float) {
    return {disc({0.1f, 0.2f, 0.7f}, {0, -0.2f, -1}, 1e-2f, {1, 2, 3})};
}
std::vector<gi::VirtualAreaLight> valsNone(float) { return {}; }
std::vector<gi::VirtualAreaLight> valsOnePoint(float) {
    return std::vector<gi::VirtualAreaLight>(1000, disc({0.2f, 0, 0.5f}, {0, 0, -1}, 1e-3f, {1, 1, 1}));
}
std::vector<gi::VirtualAreaLight> valsBelow(float) {
    return randomVals(500, {-1, -1, -2}, {1, 1, -0.01f}, {0, 0, 0}, 1e-2f, 3);
}

class LightSkinExtremeGLTest : public GlTest, public ::testing::WithParamInterface<GpuExtreme> {};

TEST_P(LightSkinExtremeGLTest, FiniteNonNegativeBoundedAndAgreesWithTheReference) {
    const GpuExtreme& c = GetParam();
    Scene scene;
    scene.sceneScale = c.scale;
    Material material;
    material.specularAlbedo = {0.5f, 0.5f, 0.5f};
    material.specularExponent = c.exponent;
    scene.add(makeGrid(2.0f * c.scale, 4), glm::mat4(1.0f), material, 25);
    scene.vals = c.vals(c.scale);
    scene.eye = glm::vec3(0.3f, -0.4f, 2.0f) * c.scale;
    scene.target = glm::vec3(0.0f);
    const PaperSetup setup{"glossy", true, false};
    gi::LightSkinSettings settings;
    settings.occlusion = false;
    const GpuRun gpu = runLightSkin(scene, settings);
    const ReferenceRun r = runReference(scene, setup);
    double bound = 0.0; // sum of exitances bounds the irradiance
    for (const auto& l : scene.vals) bound += double(std::max({l.flux.x, l.flux.y, l.flux.z})) / double(l.area);
    for (std::size_t i = 0; i < r.receivers.size(); ++i)
        for (int ch = 0; ch < 3; ++ch) {
            const float e = gpu.gather[5 * i][ch];
            ASSERT_TRUE(std::isfinite(e) && std::isfinite(gpu.gather[5 * i + 2][ch]));
            EXPECT_GE(e, 0.0f);
            EXPECT_GE(gpu.gather[5 * i + 2][ch], 0.0f);
            EXPECT_LE(double(e), bound * 1.0001 + 1e-30);
        }
    for (const glm::vec4& p : gpu.image)
        for (int ch = 0; ch < 3; ++ch) {
            ASSERT_TRUE(std::isfinite(p[ch]));
            EXPECT_GE(p[ch], 0.0f);
        }
    compareStages(gpu, r, setup);
    comparePixels(gpu, r, scene, true, 5e-3);
    // Guard G1 regularises direction cosines with 1e-12 r^2 added to d^2: a relative change of
    // 0.5e-12 (r / d)^2, 1.6e-4 for the VAL 1e-6 m from the point (r = 0.018 m), x k = 20 in
    // cos^k: 3e-3, beyond the float tolerance. The guard is a documented deviation exercised only
    // there; PaperReference has none, so that case is compared with gi::reference alone.
    if (std::string(c.name) != "micron_apart") {
        SCOPED_TRACE("against PaperReference (independent formulas)");
        const ReferenceRun independent = runIndependent(scene, setup, r);
        compareStages(gpu, independent, setup);
        comparePixels(gpu, independent, scene, true, 5e-3);
    }
    if (scene.vals.empty() || std::string(c.name) == "below_horizon" || std::string(c.name) == "back_facing") {
        for (const glm::vec4& p : gpu.image) EXPECT_EQ(p, glm::vec4(0.0f)) << "no light must give exactly 0";
    }
}

INSTANTIATE_TEST_SUITE_P(
    Extremes, LightSkinExtremeGLTest,
    ::testing::Values(GpuExtreme{"coincident", 1.0f, 20.0f, valsCoincident},
                      GpuExtreme{"micron_apart", 1.0f, 20.0f, valsMicron},
                      GpuExtreme{"scale_1e-3", 1e-3f, 20.0f, valsPlane},
                      GpuExtreme{"scale_1e3", 1e3f, 20.0f, valsPlane}, GpuExtreme{"grazing", 1.0f, 20.0f, valsGrazing},
                      GpuExtreme{"back_facing", 1.0f, 20.0f, valsBackFacing}, GpuExtreme{"k_1", 1.0f, 1.0f, valsPlane},
                      GpuExtreme{"k_100", 1.0f, 100.0f, valsPlane}, GpuExtreme{"k_1e4", 1.0f, 1e4f, valsPlane},
                      GpuExtreme{"single_val", 1.0f, 20.0f, valsSingle}, GpuExtreme{"no_val", 1.0f, 20.0f, valsNone},
                      GpuExtreme{"all_at_one_point", 1.0f, 20.0f, valsOnePoint},
                      GpuExtreme{"below_horizon", 1.0f, 20.0f, valsBelow}),
    [](const auto& param_info) {
        std::string name = param_info.param.name;
        for (char& ch : name)
            if (ch == '-') ch = 'm';
        return name;
    });

// ---- invariances ---------------------------------------------------------------------------
using LightSkinInvarianceGLTest = GlTest;

double relativeImageDifference(const GpuRun& a, const GpuRun& b) {
    double largest = 0.0, worst = 0.0;
    for (const glm::vec4& p : b.image) largest = std::max({largest, double(p.x), double(p.y), double(p.z)});
    for (std::size_t i = 0; i < a.image.size(); ++i)
        for (int c = 0; c < 3; ++c) {
            const double diff = std::abs(double(a.image[i][c]) - double(b.image[i][c]));
            worst = std::max(worst, diff / std::max(double(std::abs(b.image[i][c])), 1e-2 * largest));
        }
    return worst;
}

/// Worst |a - b| / max(|b|, floorFraction * max|b|) over the slot's xyz (signed sums such as
/// the position offsets need the floor: their components cancel).
double relativeDifference(const std::vector<glm::vec4>& a, const std::vector<glm::vec4>& b, int stride, int slot,
                          double floorFraction = 0.0) {
    double largest = 0.0, worst = 0.0;
    for (std::size_t i = std::size_t(slot); i < b.size(); i += std::size_t(stride))
        for (int c = 0; c < 3; ++c) largest = std::max(largest, double(std::abs(b[i][c])));
    for (std::size_t i = std::size_t(slot); i < b.size(); i += std::size_t(stride))
        for (int c = 0; c < 3; ++c) {
            const double diff = std::abs(double(a[i][c]) - double(b[i][c]));
            if (diff > 0.0)
                worst = std::max(worst, diff / std::max(double(std::abs(b[i][c])), floorFraction * largest));
        }
    return worst;
}

/// Every stage of `a` against `b` (relative, per value; signed sums and positions with a floor of
/// 1e-2 of the stage's largest value, as relativeImageDifference has for pixels) must stay
/// within `limit`.
void expectSameStages(const GpuRun& a, const GpuRun& b, double limit, const std::string& what) {
    for (int slot : {0, 2})
        EXPECT_LE(relativeDifference(a.gather, b.gather, 5, slot), limit) << what << ", sums " << slot;
    for (int slot : {1, 3, 4})
        EXPECT_LE(relativeDifference(a.gather, b.gather, 5, slot, 1e-2), limit) << what << ", sums " << slot;
    for (int slot = 0; slot < 4; ++slot)
        EXPECT_LE(relativeDifference(a.vpls, b.vpls, 4, slot, 1e-2), limit) << what << ", renormalised VPLs " << slot;
    EXPECT_LE(relativeDifference(a.occlusion, b.occlusion, 1, 0, 1e-2), limit) << what << ", occlusion";
    for (int slot = 0; slot < 4; ++slot)
        EXPECT_LE(relativeDifference(a.vertex, b.vertex, 4, slot, 1e-2), limit) << what << ", vertex VPLs " << slot;
    EXPECT_LE(relativeImageDifference(a, b), limit) << what << ", pixels";
}

/// Invariance tests compare two runs, which two all-zero (or all-dark) runs would pass. This
/// requires the image to carry at least half of the light of the double brute force (eq. 2,
/// same VALs, no occlusion) summed over every 5th covered pixel. Derivation of the 1/2: on these
/// scenes LightSkin's interpolation error is a few percent
/// (BruteForceGLTest.LightSkinIsCloseToBruteForceOnASmoothScene: 3 %), and occlusion can only
/// remove light the geometry blocks, < 30 % of the total here (the floor under the sphere: the
/// truth measures 12 % on a similar scene, LightSkinTruthGLTest); 0.5 leaves a factor > 1.4.
void expectNonTrivial(const GpuRun& run, const Scene& scene, bool glossy, const std::string& what) {
    ref::GatherParameters parameters;
    parameters.glossy = glossy;
    double image = 0.0, brute = 0.0;
    std::size_t covered = 0;
    for (std::size_t i = 0; i < run.image.size(); ++i) {
        if (run.gbufferPosition[i].w == 0.0f || covered++ % 5 != 0) continue;
        // which instance: in the two-mesh scenes the second is the floor, the plane z = 0
        const bool floor = scene.instances.size() > 1 && std::abs(run.gbufferPosition[i].z) < 1e-4f;
        const Material& m = scene.instances[floor ? 1 : 0].material;
        const ref::Surface s{dvec3(run.gbufferPosition[i]), glm::normalize(dvec3(run.gbufferNormal[i])),
                             dvec3(m.diffuseAlbedo), dvec3(m.specularAlbedo), double(m.specularExponent)};
        const dvec3 expected = ref::bruteForce(scene.vals, s, dvec3(scene.eye), parameters);
        image += double(run.image[i].x + run.image[i].y + run.image[i].z);
        brute += expected.x + expected.y + expected.z;
    }
    ASSERT_GT(brute, 0.0) << what << ": the scene must be lit";
    EXPECT_GT(image, 0.5 * brute) << what << ": the technique must deliver the light";
}

TEST_F(LightSkinInvarianceGLTest, KCacheChangesResultsByAtMost1e5Relative) {
    // K_cache only changes how the VALs are split into gather passes. With additive blending of
    // per-pass sums that changed the float summation order: the sums moved by up to 2e-6 (L'_d)
    // and 7e-6 (sum (l - x) w, floor 1e-2), the averaged positions l' by 3e-5, the pixels by
    // 2.3e-5 (diffuse) and 1.5e-5 (glossy). The gather now adds the VALs in fixed blocks of 16
    // and carries the running sums from pass to pass (gather_sum_block.glsl), so every stage is
    // K_cache-invariant: measured bitwise equal on llvmpipe, held to 1e-5 at every stage, in the
    // diffuse and the glossy + occlusion setup, for K_cache from one pass per 16 VALs to a
    // single pass (the scene has ~1000 VALs).
    for (const bool glossy : {false, true}) {
        Scene scene = sphereOverFloor();
        gi::LightSkinSettings settings;
        settings.glossy = glossy;
        settings.occlusion = glossy;
        settings.kCache = 128;
        const GpuRun base = runLightSkin(scene, settings);
        expectNonTrivial(base, scene, glossy, "K_cache 128");
        for (int k : {16, 48, 1024}) {
            settings.kCache = k;
            expectSameStages(runLightSkin(scene, settings), base, 1e-5,
                             "K_cache " + std::to_string(k) + (glossy ? " (glossy + occlusion)" : " (diffuse)"));
        }
    }
}

TEST_F(LightSkinInvarianceGLTest, ComputeGatherMatchesTheFragmentGather) {
    // same 16-VAL sum blocks as the fragment passes (gather_sum_block.glsl): measured bitwise
    // equal on llvmpipe; held to the K_cache bound
    Scene scene = sphereOverFloor();
    gi::LightSkinSettings settings;
    const GpuRun fragment = runLightSkin(scene, settings);
    expectNonTrivial(fragment, scene, true, "fragment gather");
    settings.computeGather = true;
    for (int perDispatch : {256, 100}) { // several dispatches over the ~1000 VALs (100: rounded to 64)
        settings.computeValsPerDispatch = perDispatch;
        expectSameStages(runLightSkin(scene, settings), fragment, 1e-5,
                         "compute, " + std::to_string(perDispatch) + " VALs per dispatch");
    }
}

TEST_F(LightSkinInvarianceGLTest, DoublingSparsePointsChangesTheMeanByAtMostFivePercent) {
    Scene scene;
    Material material;
    material.specularAlbedo = {0.2f, 0.2f, 0.2f};
    scene.add(makeSphere(0.4f, 24, 48), glm::mat4(1.0f), material, 150);
    scene.productionSampler = true; // progressive: the 300-point set contains the 150-point set
    scene.vals = squareEmitter({0.0f, -0.5f, 1.5f}, {0.1f, 0.3f, -1.0f}, 2.0f, 24, {1.0f, 1.0f, 1.0f});
    gi::LightSkinSettings settings;
    const GpuRun a = runLightSkin(scene, settings);
    scene.sparseCounts[0] = 300;
    const GpuRun b = runLightSkin(scene, settings);
    double meanA = 0.0, meanB = 0.0;
    for (std::size_t i = 0; i < a.image.size(); ++i) {
        meanA += double(a.image[i].x);
        meanB += double(b.image[i].x);
    }
    expectNonTrivial(a, scene, true, "150 sparse points");
    EXPECT_NEAR(meanB / meanA, 1.0, 0.05);
}

TEST_F(LightSkinInvarianceGLTest, HalvingOrDoublingValResolutionChangesTotalLightByAtMostTwoPercent) {
    Scene scene;
    Material material;
    scene.add(makeSphere(0.4f, 16, 32), glm::mat4(1.0f), material, 150);
    gi::LightSkinSettings settings;
    auto total = [&](int resolution) {
        scene.vals = squareEmitter({0.0f, -0.5f, 1.2f}, {0.1f, 0.3f, -1.0f}, 1.5f, resolution, {1.0f, 1.0f, 1.0f});
        const GpuRun run = runLightSkin(scene, settings);
        expectNonTrivial(run, scene, true, "VAL resolution " + std::to_string(resolution));
        double sum = 0.0;
        for (const glm::vec4& p : run.image) sum += double(p.x);
        return sum;
    };
    const double base = total(32);
    EXPECT_NEAR(total(16) / base, 1.0, 0.02);
    EXPECT_NEAR(total(64) / base, 1.0, 0.02);
}

// ---- model only what the scene requires ---------------------------------------------------
// What the adaptive mode saves in time is a benchmark (`lightskin bench --adaptive off,on`,
// docs/BENCHMARKS.md), not asserted here: wall-clock ratios flake on a shared 2-core machine. The
// work it drops is asserted instead: half the VALs gathered, no glossy or occlusion pass.
TEST_F(LightSkinInvarianceGLTest, AdaptiveModeDropsUnneededWorkWithinTolerance) {
    // One convex, purely diffuse object; half of the VALs face away from it.
    Scene scene;
    Material material;
    scene.add(makeSphere(0.4f, 16, 32), glm::mat4(1.0f), material, 400);
    scene.vals = squareEmitter({0.0f, 0.0f, 1.2f}, {0.0f, 0.2f, -1.0f}, 1.5f, 64, {1.0f, 1.0f, 1.0f});
    const auto away = squareEmitter({0.0f, 0.0f, -1.2f}, {0.0f, 0.0f, -1.0f}, 1.5f, 64, {1.0f, 1.0f, 1.0f});
    scene.vals.insert(scene.vals.end(), away.begin(), away.end());
    gi::LightSkinSettings settings; // glossy + occlusion requested
    const GpuRun full = runLightSkin(scene, settings);
    expectNonTrivial(full, scene, true, "full");
    settings.adaptive = true;
    gi::LightSkinChoice choice;
    const GpuRun adaptive = runLightSkin(scene, settings, &choice);
    EXPECT_FALSE(choice.glossy);
    EXPECT_FALSE(choice.occlusion);
    EXPECT_EQ(choice.valsGathered, choice.valsIn / 2);
    EXPECT_FALSE(choice.reason.empty());
    // Tolerance 1e-5 relative (float summation order of the culled set; the dropped VALs and
    // channels contribute exactly 0 apart from eps_l = 1e-20 in the averaged positions).
    EXPECT_LE(relativeImageDifference(adaptive, full), 1e-5);
}

TEST_F(LightSkinInvarianceGLTest, EmptyValSetGivesExactlyZeroAndStageTimesAreReported) {
    Scene scene = sphereOverFloor();
    scene.vals.clear();
    const GpuRun run = runLightSkin(scene, {});
    for (const glm::vec4& p : run.image) EXPECT_EQ(p, glm::vec4(0.0f));
    ASSERT_EQ(run.times.size(), 6u);
    EXPECT_EQ(run.times[1].name, "gather");
    EXPECT_EQ(run.times[5].name, "shading");
}

TEST_F(LightSkinInvarianceGLTest, RejectsABadKCache) {
    gi::LightSkinSettings settings;
    settings.kCache = 100;
    const gi::SparsePointProvider provider = [](const gi::MeshInstance&) { return gi::SparsePointSet{}; };
    EXPECT_THROW((void)gi::LightSkinIllumination::create(settings, provider), lightskin::Error);
}

} // namespace
} // namespace lightskin::test
