// LightSkin on the GPU against the Embree ground truth (gi::RayTracedGroundTruth) on three scenes:
// a convex object over a floor, a concave object (a trough) and an object close to a VAL wall.
// Setups as in the paper: diffuse; + glossy; + occlusion. The first two approximate the
// unoccluded integral and are compared with the truth without visibility; the third with
// visibility (shadow rays against the virtual meshes).
//
// The truth uses the same disc model (eq. 3, disc-centre mode) and the same
// glossy term (eq. 5) as the core, so what is measured is the technique's approximation only:
// sparse gather + averaged VPLs + eq. 12-13 interpolation + per-pixel eq. 10, and the occlusion
// model of section 3.3. Every pixel the G-buffer covers is a truth receiver (its G-buffer
// position, normal and view direction), so both sides see the same points.
//
// Error budgets, derived from the scene before the run (not from measured errors), per pixel from
// the scene's VALs and geometry (interpolationBudget() below), then summed like the error:
//  * reach: a pixel's value comes from the sparse points eq. 12-13 average at the vertices of its
//    triangle: the distance term (1 - d_j / d_max) gives the farthest of the 8 neighbours weight 0,
//    so they lie within d_8 ~ sqrt(8 / pi) h = 1.6 h of the vertex (h = sqrt(A / N), the nominal
//    spacing). Every term below is second order in the offsets (the first order cancels between
//    neighbours on several sides), so what counts is the weighted mean square offset: with weights
//    (1 - d / d_8) over a uniformly filled disc it is 0.3 d_8^2 (int (1 - r/R) r^3 dr / int (1 -
//    r/R) r dr = R^2 (1/20) / (1/6)), and the rasteriser's linear interpolation of the vertices
//    adds at most the circumradius^2 e^2 / 3 of a triangle of longest edge e:
//    delta^2 = 0.3 (1.6 h)^2 + e^2 / 3.
//  * what is interpolated is the averaged VPL (position, flux, rbar^2), and eq. 10 re-evaluates
//    distance and both cosines at the pixel; the renormalisation (eq. 11) makes it exact at each
//    sparse point. For one light the VPL is the light at every sparse point (no error at all); for
//    many, their weights change with the receiver through 1/r^2 and the cosines, and the error
//    is at most the whole second-order change of the irradiance, 3 (delta / r_eff)^2 (3 = the
//    second-order coefficient of 1/r^2 along the displacement), with 1 / r_eff^2 the
//    irradiance-weighted mean of 1 / r_j^2 over the VALs.
//  * horizon: the pixel normal differs from its neighbours' by up to Delta = delta / R (R the
//    surface's radius of curvature; 0 on planes; across the trough's 90-degree creases eq. 12's
//    normal term clamp(n_v . n_j, 0, 1) gives the other face's points weight 0). Lights within
//    Delta of the pixel's horizon may be above one sparse point's horizon and below the pixel's:
//    each is wrong by at most its light at elevation Delta, M_j w_j sin(Delta).
//  * glossy: the mirror direction turns by Delta_g = 2 Delta + delta / |eye - x| (normal twice,
//    plus the view direction); a cos^k lobe's relative second derivative in the angle is
//    k^2 tan^2(gamma) - k / cos^2(gamma), so each light's glossy term may be off by
//    (1/2) Delta_g^2 (k + k^2 tan^2 gamma) (capped at 1), on top of the diffuse terms.
//  * narrow lobes (NarrowGlossyLobes, k = 16 and 64 besides the scenes' k = 2): the glossy setup
//    against the same truth and budget; the lobe term above grows as k + k^2 tan^2 gamma, so a
//    narrow lobe gets a wider budget where the mirror direction turns between sparse points (the
//    averaged glossy VPL cannot follow a lobe narrower than the light's spread: that is the method,
//    and the budget says how much). Injected: cos^k with k capped at 8 in ls_cosPow fails every
//    scene at k = 16 and 64 (0.27-2.6 > 0.014-0.18; k = 2 cannot see it); k / 2 in the pixel's
//    eq. 10 lobe (ls_applyGlossy) fails the convex scene at k = 2 and 16 and the trough at 16
//    (at 64 it stays inside the wider budget).
//  * the VALs as samples of the lobe (checkLobeSampling, every glossy setup): LightSkin and the
//    truth above both evaluate each VAL's lobe at its centre, so what that costs against the VALs'
//    discs integrated (the truth's 8 x 16 quadrature per disc) is bounded separately: a disc of
//    angular radius alpha = r / d, midpoint-evaluated, is off by (alpha^2 / 8) |lap f / f| of its
//    lobe f = cos^k gamma (the mean of a function over a disc, second order; the first cancels),
//    |lap f / f| <= k^2 tan^2 gamma + k / cos^2 gamma + k, capped by the lobe's range over the disc
//    [cos^k(gamma + alpha), cos^k(gamma - alpha)]; plus 2 alpha^2 of it for eq. 3's point-disc weight
//    against the integrated one; a VAL within alpha of the horizon by its whole lobe maximum. With
//    these VAL spacings (0.04-0.13 m at 0.1-1.5 m, alpha <= ~0.2) the lobe at k = 64 (width
//    1 / sqrt(k) = 0.125 rad) still spans several VALs, so the discrete sum stays close to the
//    integral (Poisson summation: a Gaussian sampled at spacing s has relative error
//    ~ 2 exp(-2 pi^2 sigma^2 / s^2)); the budget says where it would not. Together with the
//    comparison above this bounds LightSkin against the discs' integral by the sum of both budgets.
//  * occlusion (section 3.3, eq. 14): each sparse point x_j multiplies its gathered light by
//    (1 - o_j), o_j = the summed overlap of the other points' occluder discs with S_o, clamped to 1.
//    What the model gets wrong, and what follows for o_j against the truth's blocked fraction b_j
//    (b = 1 - visible / unoccluded, per receiver, from the truth):
//     - the discs' area: radius = the farthest mesh vertex in the point's Voronoi region, so on a
//       mesh coarser than the sparse spacing the discs stop short of the region's boundary and
//       cover kappa = sum pi r_i^2 / area of the surface (kappa = 0.63-0.78 here: discCoverage(),
//       computed from the sparse points, not from a run). A light the real surface hides is
//       hidden by the discs with probability ~kappa.
//     - the sum over occluders ("double occlusion"): a ray blocked by a closed object crosses two
//       of its surfaces (front and back; both sets of discs face x and count), an open sheet one.
//       So the summed o_j ~ m kappa b_j, m = the surfaces per blocked ray (TruthScene::
//       occluderLayers: 2 for the spheres, 1 for the trough's open walls), clamped to 1. The
//       closed sphere is why the convex and near-wall scenes over-occlude (2 kappa ~ 1.4-1.5 > 1)
//       while the trough under-occludes (kappa ~ 0.65 < 1); the discs cannot tell a front from a
//       back face, so no choice of radius is right for both.
//     - the number of sparse points: o is computed at the sparse points and reaches a pixel
//       through eq. 12-13 and the rasteriser, a convex combination of the o_j within the reach
//       delta (above), so the pixel's o lies within [min, max] of the sparse points' o_j there.
//    Hence per receiver, with [bLow, bHigh] the range of the truth's b over the receivers of the
//    same mesh within delta and kappa over the scene's meshes, o lies in
//    [min(1, m kappaMin bLow), min(1, m kappaMax bHigh)], and the allowed error of the pixel is the
//    farthest end of that interval from its own b, times its unoccluded light (occlusionBudget()).
//    Not modelled (no bound follows from the scene, left inside the margin between the interval's
//    ends): the quad shapes (a square of the same area as a disc differs from it by 18 % of the
//    area) and eq. 14's projected centres, and S_o standing for the real spread of the VALs. The
//    budget is summed like the error; it is below the error of no occlusion (sum U b / sum V) on
//    every scene (0.92, 0.59, 0.57 of it), and on top the test asserts that occlusion beats no
//    occlusion. Injected errors (temporary edit of ls_occluderAmount, rebuild, run; reverted):
//    occluder radius doubled: all three scenes fail (0.35 > 0.16, 0.47 > 0.26, 0.49 > 0.41);
//    occlusion off (radius 0): the trough and near wall fail their budgets (0.43 > 0.26,
//    0.58 > 0.41) and all three the occlusion-beats-none check; radius halved: the trough fails
//    (0.36 > 0.26); the spheres pass, as halving the discs there offsets the double count (convex
//    0.082, better than the real model's 0.123; near wall 0.367 < 0.41).
//  The light weights use the point-disc form factor M_j A_j cos_e cos_i / (pi r^2), the glossy
//  weights eq. 5. Each pixel's diffuse part (of the truth) is allowed min(1, parallax + horizon)
//  of itself, its glossy part min(1, parallax + horizon + lobe); the image budget is their sum
//  over the pixels divided by the truth's sum, plus the occlusion budget; asserted on the relative L1 error
//  sum |LightSkin - truth| / sum truth over all covered pixels (which also bounds the bias). The
//  model before (first version: (1/2) (1.5 h / l)^2 with l the distance to the nearest
//  VAL or the curvature radius, the worst mesh for the whole image) sat 30-100x above the errors.
#include "GlTestEnvironment.h"
#include "common/GatherTestScenes.h"
#include "common/GpuRig.h"

#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gi/common/SparsePointSampler.h>
#include <lightskin/gi/lightskin/LightSkinIllumination.h>
#include <lightskin/gi/reference/RayTracedGroundTruth.h>
#include <lightskin/gl/Objects.h>

#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
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

constexpr float kExponent = 2.0f; // Phong k of every material unless a test sets another

Material material(float exponent = kExponent) {
    Material m;
    m.diffuseAlbedo = glm::vec3(0.7f);
    m.specularAlbedo = glm::vec3(0.3f);
    m.specularExponent = exponent;
    return m;
}

struct TruthScene : GpuRig {
    std::vector<gi::VirtualAreaLight> vals;
    /// per mesh: radius of curvature R of the budget (metres; infinity for planes)
    std::vector<double> curvatureRadius;
    float exponent = kExponent; ///< Phong k of every mesh's material (eq. 5)
    /// surfaces a ray the scene's occluders block crosses: 2 for a closed object, 1 for an open sheet (occlusion
    /// budget at the top)
    int occluderLayers = 1;
    void addMesh(TriangleMesh mesh, const glm::mat4& transform, std::size_t points, double radius) {
        add(std::move(mesh), transform, material(), points);
        curvatureRadius.push_back(radius);
    }
};

/// A sphere of radius 0.3 m 5 cm above a 2 x 2 m floor; a VAL wall on one side (x = -1.2 m,
/// z 0.2..1.4 m) and a VAL ceiling (the sphere changes the floor's light only by occlusion, which
/// has its own budget term).
TruthScene convexOverFloor() {
    TruthScene s;
    s.addMesh(makeSphere(0.3f, 24, 48), glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 0.35f}), 512, 0.3);
    s.addMesh(makeGrid(2.0f, 24), glm::mat4(1.0f), 1024, std::numeric_limits<double>::infinity());
    s.vals = squareEmitter({-1.2f, 0.0f, 0.8f}, {1.0f, 0.0f, 0.0f}, 1.2f, 16, {1.0f, 0.9f, 0.8f});
    const auto ceiling = squareEmitter({0.2f, 0.3f, 1.6f}, {0.0f, 0.0f, -1.0f}, 1.5f, 12, {0.8f, 0.8f, 1.0f});
    s.vals.insert(s.vals.end(), ceiling.begin(), ceiling.end());
    s.eye = {1.6f, -1.8f, 1.5f};
    s.target = {0.0f, 0.0f, 0.3f};
    s.occluderLayers = 2; // the sphere
    return s;
}

/// A U-shaped trough (floor 1 x 0.5 m, walls 0.4 m high, normals inward): concave, its walls
/// shadow its floor; three planes (R infinite; the creases are cut by eq. 12's normal term); VALs
/// above and to one side.
TruthScene concaveTrough() {
    TruthScene s;
    TriangleMesh trough = makeRectangle({-0.5f, -0.25f, 0.0f}, {1.0f, 0.0f, 0.0f}, {0.0f, 0.5f, 0.0f}, 20, 10);
    append(trough, makeRectangle({-0.5f, -0.25f, 0.4f}, {1.0f, 0.0f, 0.0f}, {0.0f, 0.0f, -0.4f}, 20, 8));
    append(trough, makeRectangle({-0.5f, 0.25f, 0.0f}, {1.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.4f}, 20, 8));
    s.addMesh(std::move(trough), glm::mat4(1.0f), 512, std::numeric_limits<double>::infinity());
    s.vals = squareEmitter({0.0f, 0.0f, 1.2f}, {0.0f, 0.2f, -1.0f}, 1.5f, 16, {1.0f, 1.0f, 1.0f});
    const auto side = squareEmitter({0.0f, -1.2f, 0.8f}, {0.0f, 1.0f, -0.5f}, 1.2f, 12, {1.0f, 0.7f, 0.5f});
    s.vals.insert(s.vals.end(), side.begin(), side.end());
    s.eye = {1.2f, 0.6f, 1.6f};
    s.target = {0.0f, 0.0f, 0.15f};
    return s;
}

/// A sphere of radius 0.3 m with its side 10 cm from a wall of VALs (the real wall next to a
/// virtual object, x = -0.4 m, z 0.15..1.35 m), over a floor that ends at the wall. The sphere
/// gets 1024 sparse points (h = 0.033 m) for its 10 cm to the wall.
TruthScene nearWall() {
    TruthScene s;
    s.addMesh(makeSphere(0.3f, 32, 64), glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 0.4f}), 1024, 0.3);
    s.addMesh(makeGrid(1.6f, 24), glm::translate(glm::mat4(1.0f), {0.4f, 0.0f, 0.0f}), 512,
              std::numeric_limits<double>::infinity());
    s.vals = squareEmitter({-0.4f, 0.0f, 0.75f}, {1.0f, 0.0f, 0.0f}, 1.2f, 30, {1.0f, 0.9f, 0.8f});
    s.eye = {1.5f, -1.2f, 1.2f};
    s.target = {0.0f, 0.0f, 0.35f};
    s.occluderLayers = 2; // the sphere
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
    /// Back faces (G-buffer normal w = 1), left out of the comparison: the concave trough is an open sheet, and the
    /// camera sees the outside of its far wall from behind. LightSkin gives back faces 0 (gi::GBufferView::worldNormal:
    /// right for the inside of a nearly closed object, gi_back_face_hole_gl_test; a sheet's back side is its
    /// documented exception, as LightSkin's sparse points gather the front side's light only), so there they are
    /// asserted 0. (Before the facing flag gi::SimpleGBuffer kept the front side's normal on them, and this test
    /// compared the light of the side the camera does not see.)
    std::vector<std::size_t> backFacePixels;
    std::vector<gi::GroundTruthReceiver> receivers;
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
        if (image.normal[i].w == 1.0f) {
            t.backFacePixels.push_back(i);
            continue;
        }
        gi::GroundTruthReceiver r;
        r.position = glm::dvec3(image.position[i]);
        r.normal = glm::normalize(glm::dvec3(image.normal[i]));
        r.toViewer = glm::normalize(glm::dvec3(scene.eye) - r.position);
        r.material = material(scene.exponent);
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
    t.receivers = std::move(receivers);
    return t;
}

/// The interpolation model's allowed error at one receiver (derivation at the top): the allowed
/// fractions of its diffuse and of its glossy light. `reach` = delta, `normalTurn` = Delta.
struct PixelBudget {
    double diffuse = 0.0, glossy = 0.0;
};
PixelBudget interpolationBudget(const std::vector<gi::VirtualAreaLight>& vals, const gi::GroundTruthReceiver& r,
                                double reach, double normalTurn, double viewTurn) {
    const double k = double(r.material.specularExponent),
                 sinTurn = std::sin(std::min(normalTurn, 0.5 * std::numbers::pi));
    const double glossyTurn = 2.0 * normalTurn + viewTurn;
    double irradiance = 0.0, inverseR2 = 0.0, horizon = 0.0, glossy = 0.0, glossyOff = 0.0;
    for (const gi::VirtualAreaLight& v : vals) {
        const glm::dvec3 d = glm::dvec3(v.position) - r.position;
        const double r2 = glm::dot(d, d), dist = std::sqrt(r2);
        const glm::dvec3 toLight = d / dist;
        const double cosE = std::max(0.0, -glm::dot(glm::dvec3(v.normal), toLight));
        const double cosI = glm::dot(r.normal, toLight);
        const double mw = double(v.flux.x + v.flux.y + v.flux.z) * cosE / (std::numbers::pi * r2); // M_j w_j
        if (std::abs(cosI) < sinTurn) horizon += mw * sinTurn;
        if (cosI <= 0.0) continue;
        irradiance += mw * cosI;
        inverseR2 += mw * cosI / r2;
        const glm::dvec3 mirror = 2.0 * cosI * r.normal - toLight;
        const double cosGamma = glm::dot(mirror, r.toViewer);
        if (cosGamma <= 0.0) continue;
        const double lobe = mw * std::pow(cosGamma, k); // eq. 5 up to the constant f_s c (k + 1)
        const double tan2 = (1.0 - cosGamma * cosGamma) / (cosGamma * cosGamma);
        glossy += lobe;
        glossyOff += lobe * std::min(1.0, 0.5 * glossyTurn * glossyTurn * (k + k * k * tan2));
    }
    if (!(irradiance > 0.0)) return {};
    const double parallax = 3.0 * reach * reach * inverseR2 / irradiance;
    const double diffuse = std::min(1.0, parallax + horizon / irradiance);
    return {diffuse, glossy > 0.0 ? std::min(1.0, diffuse + glossyOff / glossy) : diffuse};
}

/// How well the discrete VALs sample the glossy lobe at one receiver (derivation at the top): the allowed difference
/// between the centre-mode glossy term (each VAL's lobe at its centre, what LightSkin and the truth above use) and
/// the lobe integrated over each VAL's disc, as a fraction of the centre-mode glossy term.
double lobeSamplingBudget(const std::vector<gi::VirtualAreaLight>& vals, const gi::GroundTruthReceiver& r) {
    const double k = double(r.material.specularExponent), halfPi = 0.5 * std::numbers::pi;
    const auto lobeAt = [k](double gamma) {
        return gamma >= 0.5 * std::numbers::pi ? 0.0 : std::pow(std::cos(gamma), k);
    };
    double glossy = 0.0, allowed = 0.0;
    for (const gi::VirtualAreaLight& v : vals) {
        const glm::dvec3 d = glm::dvec3(v.position) - r.position;
        const double r2 = glm::dot(d, d), dist = std::sqrt(r2);
        const glm::dvec3 toLight = d / dist;
        const double cosE = std::max(0.0, -glm::dot(glm::dvec3(v.normal), toLight));
        const double mw = double(v.flux.x + v.flux.y + v.flux.z) * cosE / (std::numbers::pi * r2);
        const double alpha2 = double(v.area) / std::numbers::pi / r2, alpha = std::sqrt(alpha2); // disc's angle
        const double cosI = glm::dot(r.normal, toLight);
        const glm::dvec3 mirror = 2.0 * cosI * r.normal - toLight;
        const double gamma = std::acos(std::clamp(glm::dot(mirror, r.toViewer), -1.0, 1.0));
        const double high = lobeAt(std::max(0.0, gamma - alpha)), low = lobeAt(std::min(halfPi, gamma + alpha));
        if (std::abs(cosI) < std::sin(std::min(alpha, halfPi))) { // straddles the horizon: any part of its light
            allowed += mw * high;
            if (cosI > 0.0) glossy += mw * lobeAt(gamma);
            continue;
        }
        if (cosI <= 0.0) continue;
        const double lobe = lobeAt(gamma);
        glossy += mw * lobe;
        const double cosG = std::cos(std::min(gamma, halfPi)),
                     tan2 = cosG > 0.0 ? (1.0 - cosG * cosG) / (cosG * cosG) : 0.0;
        const double secondOrder =
            cosG > 0.0 ? lobe * alpha2 / 8.0 * (k * k * tan2 + k / (cosG * cosG) + k) : high; // (alpha^2/8) |lap f / f|
        allowed += mw * (std::min(secondOrder, std::max(high - lobe, lobe - low)) + 2.0 * alpha2 * lobe);
    }
    return glossy > 0.0 ? allowed / glossy : 0.0;
}

/// The discrete VALs against their discs integrated (the truth's 8 x 16 quadrature per disc, no occluders) for the
/// glossy term on every 8th receiver: the difference must stay within lobeSamplingBudget(), summed like it.
void checkLobeSampling(const TruthScene& scene, const Truth& truth) {
    std::vector<gi::GroundTruthReceiver> receivers;
    std::vector<gi::GroundTruthResult> centre;
    for (std::size_t k = 0; k < truth.receivers.size(); k += 8) {
        receivers.push_back(truth.receivers[k]);
        centre.push_back(truth.unoccluded[k]);
    }
    const gi::RayTracedGroundTruth noOccluders = gi::RayTracedGroundTruth::create({});
    gi::GroundTruthSettings settings; // default: 8 rings x 16 sectors per disc
    settings.visibility = false;
    settings.threads = 2;
    std::vector<gi::GroundTruthResult> integrated(receivers.size());
    noOccluders.compute(scene.vals, receivers, integrated, settings);
    const double rho = double(material(scene.exponent).diffuseAlbedo.x) / std::numbers::pi;
    double sumGlossy = 0.0, sumError = 0.0, allowed = 0.0;
    for (std::size_t i = 0; i < receivers.size(); ++i) {
        const double fraction = lobeSamplingBudget(scene.vals, receivers[i]);
        for (int c = 0; c < 3; ++c) {
            const double atCentres = centre[i].radiance[c] - rho * centre[i].irradiance[c];
            const double overDiscs = integrated[i].radiance[c] - rho * integrated[i].irradiance[c];
            sumGlossy += atCentres;
            sumError += std::abs(atCentres - overDiscs);
            allowed += fraction * atCentres;
        }
    }
    ASSERT_GT(sumGlossy, 0.0);
    std::printf("  lobe sampling, k = %g: discrete VALs vs discs integrated, relative L1 %.4f of the glossy term "
                "(budget %.4f), %zu receivers\n",
                double(scene.exponent), sumError / sumGlossy, allowed / sumGlossy, receivers.size());
    EXPECT_LE(sumError, allowed) << "the discrete VALs must sample the lobe within the derived budget";
}

/// Index of the mesh whose (world) vertex is nearest to `p`: which surface a G-buffer pixel shows.
std::size_t nearestMesh(const TruthScene& scene, const glm::dvec3& p) {
    std::size_t best = 0;
    double bestD2 = std::numeric_limits<double>::infinity();
    for (std::size_t m = 0; m < scene.meshes.size(); ++m)
        for (const glm::vec3& v : scene.meshes[m].positions) {
            const glm::dvec3 w = glm::dvec3(scene.instances[m].world_T_model * glm::vec4(v, 1.0f));
            const double d2 = glm::dot(w - p, w - p);
            if (d2 < bestD2) {
                bestD2 = d2;
                best = m;
            }
        }
    return best;
}

/// Fraction of mesh m's surface its sparse points' occluder discs cover, sum pi r_i^2 / area (kappa in the
/// occlusion budget at the top). Discs are sized by the farthest mesh vertex of their Voronoi region, so on a mesh
/// coarser than the sparse spacing they stop short of the region's boundary and kappa < 1.
double discCoverage(const TruthScene& scene, std::size_t m) {
    double discs = 0.0;
    for (const gi::SparsePoint& p : scene.sparsePoints(m).points)
        discs += std::numbers::pi * double(p.occluderRadius) * double(p.occluderRadius);
    return discs / gi::surfaceArea(scene.meshes[m]);
}

/// The occlusion model's allowed error per receiver, as a fraction of its unoccluded light (derivation at the
/// top): with b the truth's blocked fraction at the receiver and [bLow, bHigh] its range over the receivers of
/// the same mesh within `reach`, the model's occlusion lies in [kappaMin bLow, min(1, 2 kappaMax bHigh)]; the
/// allowance is the farthest end of that interval from b.
std::vector<double> occlusionBudget(const TruthScene& scene, const Truth& truth, const std::vector<std::size_t>& mesh,
                                    const std::vector<double>& reach) {
    double kappaMin = std::numeric_limits<double>::infinity(), kappaMax = 0.0;
    for (std::size_t m = 0; m < scene.meshes.size(); ++m) {
        const double kappa = discCoverage(scene, m);
        kappaMin = std::min(kappaMin, kappa);
        kappaMax = std::max(kappaMax, kappa);
    }
    const std::size_t n = truth.pixels.size();
    std::vector<double> blocked(n, 0.0);
    for (std::size_t k = 0; k < n; ++k) {
        double u = 0.0, v = 0.0;
        for (int c = 0; c < 3; ++c) {
            u += truth.unoccluded[k].radiance[c];
            v += truth.visible[k].radiance[c];
        }
        blocked[k] = u > 0.0 ? std::clamp(1.0 - v / u, 0.0, 1.0) : 0.0;
    }
    std::vector<double> allowed(n, 0.0);
    for (std::size_t k = 0; k < n; ++k) {
        double low = blocked[k], high = blocked[k];
        const double reach2 = reach[mesh[k]] * reach[mesh[k]];
        for (std::size_t j = 0; j < n; ++j) {
            if (mesh[j] != mesh[k]) continue;
            const glm::dvec3 d = truth.receivers[j].position - truth.receivers[k].position;
            if (glm::dot(d, d) > reach2) continue;
            low = std::min(low, blocked[j]);
            high = std::max(high, blocked[j]);
        }
        const double layers = double(scene.occluderLayers);
        const double modelLow = std::min(1.0, layers * kappaMin * low),
                     modelHigh = std::min(1.0, layers * kappaMax * high);
        allowed[k] = std::max(std::abs(modelLow - blocked[k]), std::abs(modelHigh - blocked[k]));
    }
    return allowed;
}

/// `scene` with Phong exponent k on every mesh (LightSkin's instances and the truth's receivers).
TruthScene withExponent(TruthScene scene, float k) {
    scene.exponent = k;
    for (gi::MeshInstance& instance : scene.instances) instance.material = material(k);
    return scene;
}

constexpr Setup kDiffuse{"diffuse", false, false}, kGlossy{"glossy", true, false}, kOcclusion{"occlusion", true, true};

void checkScene(TruthScene scene, const char* name,
                std::initializer_list<Setup> setups = {kDiffuse, kGlossy, kOcclusion}) {
    scene.productionSampler = true;
    scene.width = scene.height = 64;
    // per mesh: the rms reach delta = sqrt(0.3 (1.6 h)^2 + e^2 / 3) and the normal turn Delta = delta / R
    std::vector<double> reach, normalTurn;
    for (std::size_t m = 0; m < scene.meshes.size(); ++m) {
        const double d8 = 1.6 * gi::nominalSpacing(scene.meshes[m], int(scene.sparseCounts[m]));
        const double e = gi::longestEdge(scene.meshes[m]);
        reach.push_back(std::sqrt(0.3 * d8 * d8 + e * e / 3.0));
        normalTurn.push_back(reach.back() / scene.curvatureRadius[m]);
    }
    const double rho = double(material(scene.exponent).diffuseAlbedo.x) / std::numbers::pi;
    double previousOccludedError = -1.0;
    for (const Setup& setup : setups) {
        SCOPED_TRACE(std::string(name) + ", " + setup.name + ", k = " + std::to_string(scene.exponent));
        const Image image = renderLightSkin(scene, setup);
        const Truth truth = groundTruth(scene, image);
        ASSERT_GT(truth.pixels.size(), image.position.size() / 8) << "the scene must fill the image";
        for (const std::size_t pixel : truth.backFacePixels) {
            ASSERT_EQ(image.radiance[pixel], glm::vec4(0.0f)) << "back-face pixel " << pixel;
        }
        double sumTruth = 0.0, sumTechnique = 0.0, sumError = 0.0, sumDiffuse = 0.0, sumGlossy = 0.0;
        double sumVisible = 0.0, sumUnoccluded = 0.0, sumErrorVsVisible = 0.0;
        double allowedDiffuse = 0.0, allowedGlossy = 0.0; // the interpolation budget, summed like the error
        double allowedOcclusion = 0.0;                    // the occlusion budget, summed like the error
        std::vector<std::size_t> mesh(truth.pixels.size());
        for (std::size_t k = 0; k < truth.pixels.size(); ++k) mesh[k] = nearestMesh(scene, truth.receivers[k].position);
        const std::vector<double> occlusionAllowed = setup.occlusion ? occlusionBudget(scene, truth, mesh, reach)
                                                                     : std::vector<double>(truth.pixels.size(), 0.0);
        for (std::size_t k = 0; k < truth.pixels.size(); ++k) {
            const gi::GroundTruthResult& reference = setup.occlusion ? truth.visible[k] : truth.unoccluded[k];
            const gi::GroundTruthReceiver& receiver = truth.receivers[k];
            const std::size_t m = mesh[k];
            const PixelBudget allowed =
                interpolationBudget(scene.vals, receiver, reach[m], normalTurn[m],
                                    reach[m] / glm::length(glm::dvec3(scene.eye) - receiver.position));
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
                allowedDiffuse += diffusePart * allowed.diffuse;
                allowedGlossy += (expected - diffusePart) * allowed.glossy;
                sumVisible += truth.visible[k].radiance[c];
                sumUnoccluded += truth.unoccluded[k].radiance[c];
                allowedOcclusion += truth.unoccluded[k].radiance[c] * occlusionAllowed[k];
                sumErrorVsVisible += std::abs(actual - truth.visible[k].radiance[c]);
            }
        }
        ASSERT_GT(sumTruth, 0.0);
        const double blocked = 1.0 - sumVisible / sumUnoccluded;
        const double occlusionBudgetShare = allowedOcclusion / sumTruth;
        const double budget = (allowedDiffuse + allowedGlossy + allowedOcclusion) / sumTruth;
        const double diffuseBudget = allowedDiffuse / sumDiffuse,
                     glossyBudget = sumGlossy > 0.0 ? allowedGlossy / sumGlossy : 0.0;
        const double error = sumError / sumTruth;
        std::printf("%s, %s, k = %g: relative L1 %.4f (budget %.4f: diffuse %.4f, glossy %.4f, occlusion %.4f; "
                    "blocked %.4f, no occlusion's error %.4f), mean ratio %.4f, glossy share %.3f\n",
                    name, setup.name, double(scene.exponent), error, budget, diffuseBudget, glossyBudget,
                    occlusionBudgetShare, blocked, (sumUnoccluded - sumVisible) / sumVisible, sumTechnique / sumTruth,
                    sumGlossy / sumTruth);
        EXPECT_LE(error, budget);
        EXPECT_GT(sumTechnique, 0.5 * sumTruth) << "LightSkin must deliver the light, not zeros";
        if (setup.glossy) {
            EXPECT_GT(sumGlossy, 0.05 * sumTruth) << "the glossy channel must matter";
        }
        if (setup.glossy && !setup.occlusion) checkLobeSampling(scene, truth);
        // occlusion must bring the image closer to the truth with visibility than no occlusion
        // (the technique's claim, section 3.3): compare with the glossy setup's error
        if (setup.glossy && !setup.occlusion) previousOccludedError = sumErrorVsVisible / sumVisible;
        if (setup.occlusion) {
            EXPECT_GT(blocked, 0.02) << "the scene must shadow itself";
            // the derived budget must be tighter than what no occlusion at all would score
            EXPECT_LT(occlusionBudgetShare, (sumUnoccluded - sumVisible) / sumVisible);
            EXPECT_LT(error, previousOccludedError) << "occlusion on must beat occlusion off against visibility";
        }
    }
}

using LightSkinTruthGLTest = GlTest;

TEST_F(LightSkinTruthGLTest, ConvexObjectOverAFloor) { checkScene(convexOverFloor(), "convex over floor"); }
TEST_F(LightSkinTruthGLTest, ConcaveObject) { checkScene(concaveTrough(), "concave trough"); }
TEST_F(LightSkinTruthGLTest, ObjectCloseToAWall) { checkScene(nearWall(), "near wall"); }

TEST_F(LightSkinTruthGLTest, NarrowGlossyLobes) {
    for (const float k : {16.0f, 64.0f}) {
        checkScene(withExponent(convexOverFloor(), k), "convex over floor", {kGlossy});
        checkScene(withExponent(concaveTrough(), k), "concave trough", {kGlossy});
        checkScene(withExponent(nearWall(), k), "near wall", {kGlossy});
    }
}

} // namespace
} // namespace lightskin::test
