// LightSkin on the GPU against the Embree ground truth (gi::RayTracedGroundTruth) on three scenes:
// a convex object over a floor, a concave object (a trough) and an object close to a VAL wall.
// Setups as in the paper: diffuse; + glossy; + occlusion. The first two approximate the
// unoccluded integral and are compared with the truth without visibility; the third with
// visibility (shadow rays against the virtual meshes).
//
// The truth uses the same disc model (eq. 3, disc-centre mode) and, since issue 20, the same
// glossy term (eq. 5) as the core, so what is measured is the technique's approximation only:
// sparse gather + averaged VPLs + eq. 12-13 interpolation + per-pixel eq. 10, and the occlusion
// model of section 3.3. Every pixel the G-buffer covers is a truth receiver (its G-buffer
// position, normal and view direction), so both sides see the same points.
//
// Error budgets, derived from the scene before the run (not from measured errors):
//  * interpolation (diffuse): eq. 12-13 average the VPLs of the 8 nearest sparse points, i.e.
//    over a disc of radius ~1.5 h around a vertex (h = sqrt(A / N), the nominal spacing: 8 points
//    fill pi (1.5 h)^2 ~ 7 h^2). A light field whose relative second derivative is ~1 / l^2 is
//    then biased by ~(1/2) (1.5 h / l)^2, with l the length over which the light changes: the
//    smaller of the surface's radius of curvature and its distance to the nearest VAL.
//    Rasterising vertex values across a triangle of edge e adds (e / l)^2 / 8 (linear interpolation).
//  * glossy: the mirror direction turns twice as fast as the normal and a cos^k lobe changes on
//    an angular scale of ~1 / sqrt(k), so l shrinks to l / (2 sqrt(k)) in the same formula.
//  * occlusion: the quads-on-the-unit-circle model of S_o and the occluder discs (section 3.3)
//    can be wrong by up to about half of the light that the occluders really block: + 0.5 B,
//    with B = 1 - (truth with visibility) / (truth without), computed by the truth itself.
//  The image budget is the truth-weighted mean of the channel budgets (diffuse and glossy parts
//  of the truth's radiance), each capped at 1, plus 0.5 B; asserted on the relative L1 error
//  sum |LightSkin - truth| / sum truth over all covered pixels (which also bounds the bias).
#include "GatherTestScenes.h"
#include "GlTestEnvironment.h"
#include "GpuRig.h"

#include <lightskin/gi/LightSkinIllumination.h>
#include <lightskin/gi/RayTracedGroundTruth.h>
#include <lightskin/gi/SimpleGBuffer.h>
#include <lightskin/gi/SparsePointSampler.h>
#include <lightskin/gl/Objects.h>

#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

namespace lightskin::test {
namespace {

/// A rectangle corner + s u + t v (s, t in [0, 1]), cellsU x cellsV quads, normal u x v.
TriangleMesh makeRectangle(const glm::vec3& corner, const glm::vec3& u, const glm::vec3& v, int cellsU, int cellsV) {
    TriangleMesh mesh;
    const glm::vec3 n = glm::normalize(glm::cross(u, v));
    for (int j = 0; j <= cellsV; ++j)
        for (int i = 0; i <= cellsU; ++i) {
            mesh.positions.push_back(corner + u * (float(i) / float(cellsU)) + v * (float(j) / float(cellsV)));
            mesh.normals.push_back(n);
        }
    const auto at = [&](int i, int j) { return std::uint32_t(j * (cellsU + 1) + i); };
    for (int j = 0; j < cellsV; ++j)
        for (int i = 0; i < cellsU; ++i) {
            mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    return mesh;
}

/// Appends `b` to `a` (one mesh of several parts).
void append(TriangleMesh& a, const TriangleMesh& b) {
    const auto offset = std::uint32_t(a.positions.size());
    a.positions.insert(a.positions.end(), b.positions.begin(), b.positions.end());
    a.normals.insert(a.normals.end(), b.normals.begin(), b.normals.end());
    for (std::uint32_t i : b.indices) a.indices.push_back(i + offset);
}

constexpr float kExponent = 2.0f; // Phong k of every material (glossy budget: l / (2 sqrt(k)))

Material material() {
    Material m;
    m.diffuseAlbedo = glm::vec3(0.7f);
    m.specularAlbedo = glm::vec3(0.3f);
    m.specularExponent = kExponent;
    return m;
}

struct TruthScene : GpuRig {
    std::vector<gi::VirtualAreaLight> vals;
    std::vector<double> lightLength; ///< per mesh: l of the budget (metres)
    void addMesh(TriangleMesh mesh, const glm::mat4& transform, std::size_t points, double l) {
        add(std::move(mesh), transform, material(), points);
        lightLength.push_back(l);
    }
};

/// A sphere of radius 0.3 m 5 cm above a 2 x 2 m floor; a VAL wall on one side (x = -1.2 m,
/// z 0.2..1.4 m) and a VAL ceiling. l: sphere 0.3 m (its radius; the VALs are >= 0.6 m away);
/// floor 0.25 m (its distance to the wall's lowest VALs; the sphere changes the floor's light only
/// by occlusion, which has its own budget term).
TruthScene convexOverFloor() {
    TruthScene s;
    s.addMesh(makeSphere(0.3f, 24, 48), glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 0.35f}), 512, 0.3);
    s.addMesh(makeGrid(2.0f, 24), glm::mat4(1.0f), 1024, 0.25);
    s.vals = squareEmitter({-1.2f, 0.0f, 0.8f}, {1.0f, 0.0f, 0.0f}, 1.2f, 16, {1.0f, 0.9f, 0.8f});
    const auto ceiling = squareEmitter({0.2f, 0.3f, 1.6f}, {0.0f, 0.0f, -1.0f}, 1.5f, 12, {0.8f, 0.8f, 1.0f});
    s.vals.insert(s.vals.end(), ceiling.begin(), ceiling.end());
    s.eye = {1.6f, -1.8f, 1.5f};
    s.target = {0.0f, 0.0f, 0.3f};
    return s;
}

/// A U-shaped trough (floor 1 x 0.5 m, walls 0.4 m high, normals inward): concave, its walls
/// shadow its floor. l = 0.25 m (half its width: the light on the floor changes across it, the
/// walls see each other at 0.5 m); VALs above and to one side.
TruthScene concaveTrough() {
    TruthScene s;
    TriangleMesh trough = makeRectangle({-0.5f, -0.25f, 0.0f}, {1.0f, 0.0f, 0.0f}, {0.0f, 0.5f, 0.0f}, 20, 10);
    append(trough, makeRectangle({-0.5f, -0.25f, 0.4f}, {1.0f, 0.0f, 0.0f}, {0.0f, 0.0f, -0.4f}, 20, 8));
    append(trough, makeRectangle({-0.5f, 0.25f, 0.0f}, {1.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.4f}, 20, 8));
    s.addMesh(std::move(trough), glm::mat4(1.0f), 512, 0.25);
    s.vals = squareEmitter({0.0f, 0.0f, 1.2f}, {0.0f, 0.2f, -1.0f}, 1.5f, 16, {1.0f, 1.0f, 1.0f});
    const auto side = squareEmitter({0.0f, -1.2f, 0.8f}, {0.0f, 1.0f, -0.5f}, 1.2f, 12, {1.0f, 0.7f, 0.5f});
    s.vals.insert(s.vals.end(), side.begin(), side.end());
    s.eye = {1.2f, 0.6f, 1.6f};
    s.target = {0.0f, 0.0f, 0.15f};
    return s;
}

/// A sphere of radius 0.3 m with its side 10 cm from a wall of VALs (the real wall next to a
/// virtual object, x = -0.4 m, z 0.15..1.35 m), over a floor that ends at the wall. l = 0.1 m
/// for the sphere (its distance to the wall), so it gets 1024 sparse points (h = 0.033 m); the
/// floor 0.15 m (its distance to the wall's lowest VALs).
TruthScene nearWall() {
    TruthScene s;
    s.addMesh(makeSphere(0.3f, 32, 64), glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 0.4f}), 1024, 0.1);
    s.addMesh(makeGrid(1.6f, 24), glm::translate(glm::mat4(1.0f), {0.4f, 0.0f, 0.0f}), 512, 0.15);
    s.vals = squareEmitter({-0.4f, 0.0f, 0.75f}, {1.0f, 0.0f, 0.0f}, 1.2f, 30, {1.0f, 0.9f, 0.8f});
    s.eye = {1.5f, -1.2f, 1.2f};
    s.target = {0.0f, 0.0f, 0.35f};
    return s;
}

struct Setup {
    const char* name;
    bool glossy;
    bool occlusion;
};

struct Image {
    std::vector<glm::vec4> radiance, position, normal;
};

std::vector<glm::vec4> readTexels(std::uint32_t texture, int width, int height) {
    std::vector<glm::vec4> texels(std::size_t(width) * std::size_t(height));
    glGetTextureImage(texture, 0, GL_RGBA, GL_FLOAT, GLsizei(texels.size() * sizeof(glm::vec4)), texels.data());
    return texels;
}

Image renderLightSkin(TruthScene& scene, const Setup& setup) {
    scene.upload();
    gi::LightSkinSettings settings;
    settings.glossy = setup.glossy;
    settings.occlusion = setup.occlusion;
    auto technique = scene.technique(settings);
    const gi::ViewParameters view = scene.view();
    scene.gbuffer.render(scene.instances, view.clip_T_world);
    const gl::Buffer vals =
        gl::Buffer::create(GLsizeiptr(scene.vals.size() * sizeof(gi::VirtualAreaLight)), scene.vals.data(), 0);
    technique->render({vals.id(), std::uint32_t(scene.vals.size())}, scene.instances, scene.gbuffer.view(), view,
                      scene.output.id());
    return {readTexels(scene.output.id(), scene.width, scene.height),
            readTexels(scene.gbuffer.position().id(), scene.width, scene.height),
            readTexels(scene.gbuffer.normal().id(), scene.width, scene.height)};
}

/// Per covered pixel: truth radiance with and without visibility, and the diffuse part of each.
struct Truth {
    std::vector<std::size_t> pixels;
    std::vector<gi::GroundTruthResult> visible, unoccluded;
};

Truth groundTruth(const TruthScene& scene, const Image& image) {
    std::vector<gi::GroundTruthMesh> meshes;
    for (const gi::MeshInstance& instance : scene.instances)
        meshes.push_back({instance.mesh, glm::dmat4(instance.world_T_model)});
    const gi::RayTracedGroundTruth truth = gi::RayTracedGroundTruth::create(meshes);
    Truth t;
    std::vector<gi::GroundTruthReceiver> receivers;
    for (std::size_t i = 0; i < image.position.size(); ++i) {
        if (image.position[i].w == 0.0f) continue;
        gi::GroundTruthReceiver r;
        r.position = glm::dvec3(image.position[i]);
        r.normal = glm::normalize(glm::dvec3(image.normal[i]));
        r.toViewer = glm::normalize(glm::dvec3(scene.eye) - r.position);
        r.material = material();
        receivers.push_back(r);
        t.pixels.push_back(i);
    }
    gi::GroundTruthSettings settings;
    settings.discRings = settings.discSectors = 1; // the core's disc model (eq. 3), disc-centre visibility
    settings.threads = 2;
    t.visible.resize(receivers.size());
    t.unoccluded.resize(receivers.size());
    truth.compute(scene.vals, receivers, t.visible, settings);
    settings.visibility = false;
    truth.compute(scene.vals, receivers, t.unoccluded, settings);
    return t;
}

double channelBudget(double h, double l) { return std::min(1.0, 0.5 * std::pow(1.5 * h / l, 2.0)); }

void checkScene(TruthScene scene, const char* name) {
    scene.productionSampler = true;
    scene.width = scene.height = 64;
    // per-mesh budgets from spacing, tessellation and l (worst mesh counts for the whole image)
    double diffuseBudget = 0.0, glossyBudget = 0.0;
    for (std::size_t m = 0; m < scene.meshes.size(); ++m) {
        const double h = gi::nominalSpacing(scene.meshes[m], int(scene.sparseCounts[m]));
        const double l = scene.lightLength[m];
        const double raster = std::pow(gi::longestEdge(scene.meshes[m]) / l, 2.0) / 8.0;
        diffuseBudget = std::max(diffuseBudget, channelBudget(h, l) + raster);
        glossyBudget = std::max(glossyBudget, channelBudget(h, l / (2.0 * std::sqrt(double(kExponent)))) + raster);
    }
    const double rho = double(material().diffuseAlbedo.x) / std::numbers::pi;
    double previousOccludedError = -1.0;
    for (const Setup& setup :
         {Setup{"diffuse", false, false}, Setup{"glossy", true, false}, Setup{"occlusion", true, true}}) {
        SCOPED_TRACE(std::string(name) + ", " + setup.name);
        const Image image = renderLightSkin(scene, setup);
        const Truth truth = groundTruth(scene, image);
        ASSERT_GT(truth.pixels.size(), image.position.size() / 8) << "the scene must fill the image";
        double sumTruth = 0.0, sumTechnique = 0.0, sumError = 0.0, sumDiffuse = 0.0, sumGlossy = 0.0;
        double sumVisible = 0.0, sumUnoccluded = 0.0, sumErrorVsVisible = 0.0;
        for (std::size_t k = 0; k < truth.pixels.size(); ++k) {
            const gi::GroundTruthResult& reference = setup.occlusion ? truth.visible[k] : truth.unoccluded[k];
            for (int c = 0; c < 3; ++c) {
                const double diffusePart = rho * reference.irradiance[c];
                const double expected = setup.glossy ? reference.radiance[c] : diffusePart;
                const double actual = double(image.radiance[truth.pixels[k]][c]);
                ASSERT_TRUE(std::isfinite(actual));
                sumTruth += expected;
                sumTechnique += actual;
                sumError += std::abs(actual - expected);
                sumDiffuse += diffusePart;
                sumGlossy += expected - diffusePart;
                sumVisible += truth.visible[k].radiance[c];
                sumUnoccluded += truth.unoccluded[k].radiance[c];
                sumErrorVsVisible += std::abs(actual - truth.visible[k].radiance[c]);
            }
        }
        ASSERT_GT(sumTruth, 0.0);
        const double blocked = 1.0 - sumVisible / sumUnoccluded;
        const double budget = (sumDiffuse * diffuseBudget + sumGlossy * glossyBudget) / sumTruth +
                              (setup.occlusion ? 0.5 * blocked : 0.0);
        const double error = sumError / sumTruth;
        std::printf("%s, %s: relative L1 %.4f (budget %.4f: diffuse %.4f, glossy %.4f, blocked %.4f), "
                    "mean ratio %.4f, glossy share %.3f\n",
                    name, setup.name, error, budget, diffuseBudget, glossyBudget, blocked, sumTechnique / sumTruth,
                    sumGlossy / sumTruth);
        EXPECT_LE(error, budget);
        EXPECT_GT(sumTechnique, 0.5 * sumTruth) << "LightSkin must deliver the light, not zeros";
        if (setup.glossy) {
            EXPECT_GT(sumGlossy, 0.05 * sumTruth) << "the glossy channel must matter";
        }
        // occlusion must bring the image closer to the truth with visibility than no occlusion
        // (the technique's claim, section 3.3): compare with the glossy setup's error
        if (setup.glossy && !setup.occlusion) previousOccludedError = sumErrorVsVisible / sumVisible;
        if (setup.occlusion) {
            EXPECT_GT(blocked, 0.02) << "the scene must shadow itself";
            EXPECT_LT(error, previousOccludedError) << "occlusion on must beat occlusion off against visibility";
        }
    }
}

using LightSkinTruthGLTest = GlTest;

TEST_F(LightSkinTruthGLTest, ConvexObjectOverAFloor) { checkScene(convexOverFloor(), "convex over floor"); }
TEST_F(LightSkinTruthGLTest, ConcaveObject) { checkScene(concaveTrough(), "concave trough"); }
TEST_F(LightSkinTruthGLTest, ObjectCloseToAWall) { checkScene(nearWall(), "near wall"); }

} // namespace
} // namespace lightskin::test
