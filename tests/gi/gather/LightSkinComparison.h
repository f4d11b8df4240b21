#pragma once
// Shared by the LightSkin GL and CPU backend tests: the scenes (paper setups, numerical extremes),
// the double-reference pipeline on them, and the stage-by-stage comparisons with their derived
// float tolerances (see the comment at the top of LightSkinGLTest.cpp for their derivation).
#include "GatherTestScenes.h"
#include "GpuRig.h"

#include <lightskin/gi/LightSkinReference.h>
#include <lightskin/gi/SimpleGBuffer.h>
#include <lightskin/gl/Objects.h>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace lightskin::test {

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

inline std::vector<glm::vec4> readTexels(const gl::Texture& texture) {
    std::vector<glm::vec4> texels(std::size_t(texture.width()) * std::size_t(texture.height()));
    glGetTextureImage(texture.id(), 0, GL_RGBA, GL_FLOAT, GLsizei(texels.size() * sizeof(glm::vec4)), texels.data());
    return texels;
}

struct GpuRun {
    std::vector<glm::vec4> image, gbufferPosition, gbufferNormal, gather, vpls, occlusion, vertex;
    std::vector<gl::StageTime> times;
    double milliseconds = 0.0;
};

inline gl::Buffer uploadVals(const std::vector<gi::VirtualAreaLight>& vals) {
    return gl::Buffer::create(GLsizeiptr(std::max<std::size_t>(vals.size(), 1) * sizeof(gi::VirtualAreaLight)),
                              vals.empty() ? nullptr : vals.data(), 0);
}

/// One render() of a technique prepared for `scene` (after scene.upload()) with its own G-buffer
/// and target, and every stage read back (Technique: LightSkinIllumination or CpuLightSkin).
template <class Technique>
GpuRun renderAndRead(const Scene& scene, Technique& technique) {
    gi::SimpleGBuffer gbuffer = gi::SimpleGBuffer::create(scene.width, scene.height);
    const gi::ViewParameters view = scene.view();
    gbuffer.render(scene.instances, view.clip_T_world);
    gl::Texture target = gl::Texture::create2D(GL_RGBA32F, scene.width, scene.height);
    const gl::Buffer vals = uploadVals(scene.vals);
    technique.render({vals.id(), std::uint32_t(scene.vals.size())}, scene.instances, gbuffer.view(), view, target.id());
    GpuRun run;
    run.image = readTexels(target);
    run.gbufferPosition = readTexels(gbuffer.position());
    run.gbufferNormal = readTexels(gbuffer.normal());
    technique.readGatherSums(run.gather);
    technique.readSparseVpls(run.vpls);
    technique.readOcclusion(run.occlusion);
    technique.readVertexVpls(run.vertex);
    technique.lastStageTimes(run.times);
    return run;
}

struct ReferenceRun {
    std::vector<ref::Receiver> receivers;
    std::vector<ref::GatherSums> sums;
    std::vector<ref::VplPair> vpls, occluded, vertex;
    std::vector<glm::dvec2> occlusion;
    std::vector<dvec3> vertexPositions, vertexNormals;
    std::vector<std::array<std::uint32_t, 3>> triangles; // global vertex indices
    std::vector<const gi::MeshInstance*> triangleInstance;
};

inline ReferenceRun runReference(const Scene& scene, const PaperSetup& setup) {
    ReferenceRun r;
    ref::GatherParameters parameters;
    parameters.glossy = setup.glossy;
    std::vector<std::array<std::uint32_t, 8>> neighbours;
    for (std::size_t m = 0; m < scene.meshes.size(); ++m) {
        const TriangleMesh& mesh = scene.meshes[m];
        const gi::SparsePointSet set = gi::sparsePointsFromVertices(mesh, scene.sparseCounts[m]);
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

/// Per-pixel reference: the triangle under the G-buffer position, barycentric interpolation of
/// the reference vertex VPLs (what the rasteriser does, perspective-correct), eq. 10.
inline std::optional<dvec3> referencePixel(const ReferenceRun& r, const dvec3& p, const dvec3& n, const dvec3& eye,
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
        result = ref::shade(v, surface, eye);
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

inline void compareStages(const GpuRun& gpu, const ReferenceRun& r, const PaperSetup& setup) {
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
    Comparison irradiance("L'_d", 2e-4, 1e-4), glossy("L'_s", glossyRel, 1e-4), weights("W", glossyRel, 1e-4),
        offsets("sum (l - x) w", glossyRel, 1e-4), moments("moments", 2e-4, 1e-4);
    for (std::size_t i = 0; i < n; ++i) {
        const ref::GatherSums& s = r.sums[i];
        const glm::vec4* g = &gpu.gather[5 * i];
        for (int c = 0; c < 3; ++c) {
            irradiance.add(g[0][c], s.irradiance[c]);
            offsets.add(g[1][c], s.offsetD[c]);
            glossy.add(g[2][c], s.glossy[c]);
            offsets.add(g[3][c], s.offsetS[c]);
            if (setup.occlusion) moments.add(g[4][c], s.momentD[c]);
        }
        weights.add(g[1].w, s.weightD);
        weights.add(g[3].w, s.weightS);
        weights.add(g[0].w, s.r2D);
        weights.add(g[2].w, s.r2S);
        if (setup.occlusion) moments.add(g[4].w, s.momentS);
    }
    irradiance.check();
    glossy.check();
    weights.check();
    offsets.check();
    moments.check();

    Comparison vplRadiance("L''", 2e-3 + 2.4e-7 * maxExponent, 1e-4), vplPosition("l'", 0.0, 1e-4, positionFloor),
        sphere("S_o radius", 2e-3, 1e-3);
    for (std::size_t i = 0; i < n; ++i) {
        const glm::vec4* v = &gpu.vpls[4 * i];
        for (int c = 0; c < 3; ++c) {
            vplRadiance.add(v[0][c], r.vpls[i].diffuse.radiance[c]);
            vplRadiance.add(v[2][c], r.vpls[i].glossy.radiance[c]);
            vplPosition.add(v[1][c], r.vpls[i].diffuse.position[c]);
            if (setup.glossy) vplPosition.add(v[3][c], r.vpls[i].glossy.position[c]);
        }
        if (setup.occlusion) {
            sphere.add(v[1].w, r.vpls[i].diffuse.sphereRadius);
            if (setup.glossy) sphere.add(v[3].w, r.vpls[i].glossy.sphereRadius);
        }
    }
    vplRadiance.check();
    vplPosition.check();
    sphere.check();

    if (setup.occlusion) {
        Comparison occlusion("o", 0.0, 0.0);
        std::size_t bad = 0;
        for (std::size_t i = 0; i < n; ++i) {
            const double od = std::clamp(double(gpu.occlusion[i].x), 0.0, 1.0);
            if (std::abs(od - r.occlusion[i].x) > 2e-3) ++bad;
        }
        EXPECT_EQ(bad, 0u) << "occlusion amounts differ by more than 2e-3 (absolute, o in [0, 1])";
    }

    Comparison vertex("vertex VPL radiance", 3e-3 + 2.4e-7 * maxExponent, 1e-4),
        vertexPosition("vertex VPL position", 0.0, 1e-4, positionFloor);
    ASSERT_EQ(gpu.vertex.size(), 4 * r.vertex.size());
    for (std::size_t v = 0; v < r.vertex.size(); ++v) {
        const glm::vec4* g = &gpu.vertex[4 * v];
        for (int c = 0; c < 3; ++c) {
            vertex.add(g[0][c], r.vertex[v].diffuse.radiance[c]);
            vertex.add(g[2][c], r.vertex[v].glossy.radiance[c]);
            vertexPosition.add(g[1][c], r.vertex[v].diffuse.position[c]);
        }
    }
    vertex.check();
    vertexPosition.check();
}

inline void comparePixels(const GpuRun& gpu, const ReferenceRun& r, const Scene& scene, bool glossy, double rel) {
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

inline Scene sphereOverFloor() {
    Scene scene;
    Material sphereMaterial;
    sphereMaterial.diffuseAlbedo = {0.8f, 0.7f, 0.6f};
    sphereMaterial.specularAlbedo = {0.3f, 0.3f, 0.3f};
    sphereMaterial.specularExponent = 20.0f;
    scene.add(makeSphere(0.3f, 12, 24), glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 0.45f}), sphereMaterial, 120);
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

struct GpuExtreme {
    const char* name;
    float scale = 1.0f;
    float exponent = 20.0f;
    std::vector<gi::VirtualAreaLight> (*vals)(float scale);
};

inline std::vector<gi::VirtualAreaLight> valsCoincident(float) {
    return {disc({0, 0, 0}, {0, 0, -1}, 1e-3f, {1, 1, 1})};
}
inline std::vector<gi::VirtualAreaLight> valsMicron(float) {
    return {disc({0, 0, 1e-6f}, {0, 0, -1}, 1e-3f, {1, 1, 1})};
}
inline std::vector<gi::VirtualAreaLight> valsPlane(float s) {
    return squareEmitter({0.2f * s, 0.0f, 0.6f * s}, {0.1f, 0.2f, -1.0f}, s, 12, {1.0f, 0.5f, 0.25f});
}
inline std::vector<gi::VirtualAreaLight> valsGrazing(float) {
    return {disc({0.8f, 0.0f, 1e-3f}, {-1, 0, 0}, 1e-2f, {1, 1, 1}),
            disc({-0.8f, 0.0f, -1e-3f}, {1, 0, 0}, 1e-2f, {1, 1, 1}),
            disc({0.0f, 0.8f, 0.0f}, {0, -1, 0.001f}, 1e-2f, {1, 1, 1})};
}
inline std::vector<gi::VirtualAreaLight> valsBackFacing(float) {
    return squareEmitter({0, 0, 0.5f}, {0, 0, 1}, 1.0f, 8, {1, 1, 1});
}
inline std::vector<gi::VirtualAreaLight> valsSingle(float) {
    return {disc({0.1f, 0.2f, 0.7f}, {0, -0.2f, -1}, 1e-2f, {1, 2, 3})};
}
inline std::vector<gi::VirtualAreaLight> valsNone(float) { return {}; }
inline std::vector<gi::VirtualAreaLight> valsOnePoint(float) {
    return std::vector<gi::VirtualAreaLight>(1000, disc({0.2f, 0, 0.5f}, {0, 0, -1}, 1e-3f, {1, 1, 1}));
}
inline std::vector<gi::VirtualAreaLight> valsBelow(float) {
    return randomVals(500, {-1, -1, -2}, {1, 1, -0.01f}, {0, 0, 0}, 1e-2f, 3);
}

/// The numerical extremes both backends must survive (finite, non-negative, bounded, matching the reference).
inline std::vector<GpuExtreme> gpuExtremes() {
    return {GpuExtreme{"coincident", 1.0f, 20.0f, valsCoincident},
            GpuExtreme{"micron_apart", 1.0f, 20.0f, valsMicron},
            GpuExtreme{"scale_1e-3", 1e-3f, 20.0f, valsPlane},
            GpuExtreme{"scale_1e3", 1e3f, 20.0f, valsPlane},
            GpuExtreme{"grazing", 1.0f, 20.0f, valsGrazing},
            GpuExtreme{"back_facing", 1.0f, 20.0f, valsBackFacing},
            GpuExtreme{"k_1", 1.0f, 1.0f, valsPlane},
            GpuExtreme{"k_100", 1.0f, 100.0f, valsPlane},
            GpuExtreme{"k_1e4", 1.0f, 1e4f, valsPlane},
            GpuExtreme{"single_val", 1.0f, 20.0f, valsSingle},
            GpuExtreme{"no_val", 1.0f, 20.0f, valsNone},
            GpuExtreme{"all_at_one_point", 1.0f, 20.0f, valsOnePoint},
            GpuExtreme{"below_horizon", 1.0f, 20.0f, valsBelow}};
}

/// Extreme names as test names (no '-').
inline std::string extremeName(const ::testing::TestParamInfo<GpuExtreme>& info) {
    std::string name = info.param.name;
    for (char& ch : name)
        if (ch == '-') ch = 'm';
    return name;
}

inline double relativeImageDifference(const GpuRun& a, const GpuRun& b) {
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
inline double relativeDifference(const std::vector<glm::vec4>& a, const std::vector<glm::vec4>& b, int stride, int slot,
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
inline void expectSameStages(const GpuRun& a, const GpuRun& b, double limit, const std::string& what) {
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

} // namespace lightskin::test
