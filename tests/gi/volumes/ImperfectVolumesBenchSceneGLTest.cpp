// gi::ImperfectVolumes on the gather benchmarks' scene (lightskin::bench::gatherScene: a sphere 0.55 m
// above a 2.4 m floor, lit by a VAL map on a wall and the ceiling) against the Embree ground truth
// (gi::RayTracedGroundTruth) at every covered pixel, and in total. The budget of each pixel is derived
// from the voxel size and the ray count, as in ImperfectVolumesTruthGLTest: the position error of the
// SH (voxel centres around p' = p + s/2 n, silhouettes grown by the hit voxels), the quadrature error of
// eq. 3 at discontinuities, and against the exact irradiance also the L1 truncation of the cosine lobe.
//
// LightSkin (gi::LightSkinIllumination, default settings but glossy off: the volumes are diffuse, so
// both are compared on the irradiance) runs on the same scene and VALs against the same Embree truth in
// its disc model (discRings = 1, as gi_truth_gl_test), within the budget derived in
// tests/gi/lightskin/LightSkinTruthGLTest.cpp (interpolation reach and horizon terms, + the blocked light
// B since occlusion is on), asserted like there on the relative L1 error. Then the two techniques must
// agree within the sum of their budgets (+ the difference of the two truths' disc and point models).
#include "GlTestEnvironment.h"
#include "VolumesTestSupport.h"

#include <lightskin/bench/BenchScene.h>
#include <lightskin/gi/volumes/ImperfectVolumes.h>
#include <lightskin/gi/lightskin/LightSkinIllumination.h>
#include <lightskin/gi/reference/RayTracedGroundTruth.h>
#include <lightskin/gi/common/SparsePointSampler.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/gl/Readback.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

namespace lightskin::test {
namespace {

using glm::dvec3;
constexpr double kPi = std::numbers::pi;

// Red channel. Small-disc solid angle per VAL (cells of <= 6 cm at >= 0.3 m from any receiver:
// relative error O((r / d)^2) < 1 %, below the voxel terms); visibility by Embree from 0.1 mm above p.
IncidentL1 incident(const gi::RayTracedGroundTruth& rt, std::span<const gi::VirtualAreaLight> vals, const dvec3& p,
                    const dvec3& n) {
    return incidentL1(rt, vals, p, n, 1e-4);
}

/// LightSkin's interpolation budget at one receiver as a fraction of its diffuse light: the diffuse
/// part of interpolationBudget() in tests/gi/lightskin/LightSkinTruthGLTest.cpp (derivation there):
/// parallax 3 (delta / r_eff)^2 plus the horizon term sin(Delta) of the lights within Delta of the
/// horizon, capped at 1. `reach` = delta (metres), `normalTurn` = Delta (rad).
double lightSkinDiffuseBudget(std::span<const gi::VirtualAreaLight> vals, const dvec3& p, const dvec3& n, double reach,
                              double normalTurn) {
    const double sinTurn = std::sin(std::min(normalTurn, 0.5 * kPi));
    double irradiance = 0.0, inverseR2 = 0.0, horizon = 0.0;
    for (const auto& v : vals) {
        const dvec3 d = dvec3(v.position) - p;
        const double r2 = glm::dot(d, d), dist = std::sqrt(r2);
        const dvec3 toLight = d / dist;
        const double cosE = std::max(0.0, -glm::dot(dvec3(v.normal), toLight));
        const double cosI = glm::dot(n, toLight);
        const double mw = double(v.flux.x + v.flux.y + v.flux.z) * cosE / (kPi * r2);
        if (std::abs(cosI) < sinTurn) horizon += mw * sinTurn;
        if (cosI <= 0.0) continue;
        irradiance += mw * cosI;
        inverseR2 += mw * cosI / r2;
    }
    if (!(irradiance > 0.0)) return 0.0;
    return std::min(1.0, 3.0 * reach * reach * inverseR2 / irradiance + horizon / irradiance);
}

using ImperfectVolumesBenchSceneGLTest = GlTest;

TEST_F(ImperfectVolumesBenchSceneGLTest, EveryPixelAndTheTotalLightWithinTheVoxelBudgetOfTheEmbreeTruthAndOfLightSkin) {
    constexpr int kWidth = 40, kHeight = 30, kResolution = 32, kRays = 4096;
    bench::GatherScene scene = bench::gatherScene(kWidth, kHeight);
    // 40 x 40 VALs on the wall (6 x 4 cm) and on the ceiling (6 x 6 cm): spaced below the voxel edge
    // (7.8 cm), so that their points leave no hole in the occupied wall and ceiling.
    const std::vector<gi::VirtualAreaLight> vals = bench::valMap(40, 80);
    gl::Buffer valBuffer = gl::Buffer::create(GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)), vals.data());
    gl::Texture output = gl::Texture::create2D(GL_RGBA32F, kWidth, kHeight);

    // Fixed grid: x, y in [-1.25, 1.25] (the wall at x = -1.2 inside), z in [-0.2, 2.3] (floor at 0,
    // ceiling at 1.8); s = 2.5 / 32 = 7.8 cm. Wall, floor and ceiling lie 0.56-0.64 voxel into their layers.
    gi::ImperfectVolumesSettings settings;
    settings.autoFit = false;
    settings.origin = glm::vec3(-1.25f, -1.25f, -0.2f);
    settings.size = 2.5f;
    settings.resolution = kResolution;
    settings.raysPerVoxel = kRays;
    settings.pointsPerTriangle = 12; // the sphere's triangles are ~1 cm: hundreds of points per voxel
    auto technique = gi::ImperfectVolumes::create(settings);
    technique->prepare(scene.instances);
    technique->render({valBuffer.id(), std::uint32_t(vals.size())}, scene.instances, scene.gbuffer.view(), scene.view,
                      output.id());
    cv::Mat result, position, normal, albedo;
    gl::readTextureRgba32fInto(output, result);
    gl::readTextureRgba32fInto(scene.gbuffer.position(), position);
    gl::readTextureRgba32fInto(scene.gbuffer.normal(), normal);
    gl::Texture albedoTexture = gl::Texture::wrap(scene.gbuffer.view().diffuseAlbedo, kWidth, kHeight);
    gl::readTextureRgba32fInto(albedoTexture, albedo);
    (void)albedoTexture.release(); // the G-buffer owns it

    // LightSkin with the project's sparse points (1024 per mesh, production sampler; the bench meshes
    // are finer than the spacing, so no refinement is needed and the G-buffer's vertices stay valid).
    gi::SparsePointSettings sparse;
    gi::LightSkinSettings lightSkinSettings;
    lightSkinSettings.glossy = false;
    auto lightSkin = gi::LightSkinIllumination::create(lightSkinSettings, gi::samplingProvider(sparse));
    lightSkin->prepare(scene.instances);
    gl::Texture lightSkinOutput = gl::Texture::create2D(GL_RGBA32F, kWidth, kHeight);
    lightSkin->render({valBuffer.id(), std::uint32_t(vals.size())}, scene.instances, scene.gbuffer.view(), scene.view,
                      lightSkinOutput.id());
    cv::Mat lightSkinResult;
    gl::readTextureRgba32fInto(lightSkinOutput, lightSkinResult);
    // The reach delta = sqrt(0.3 (1.6 h)^2 + e^2 / 3) and normal turn Delta = delta / R per mesh
    // (LightSkinTruthGLTest's checkScene): the sphere (R = 0.4 m) and the floor (a plane).
    std::vector<double> reach, normalTurn;
    const double curvature[2] = {0.4, std::numeric_limits<double>::infinity()};
    for (std::size_t m = 0; m < 2; ++m) {
        const double d8 = 1.6 * gi::nominalSpacing(scene.meshes[m], sparse.pointCount);
        const double e = gi::longestEdge(scene.meshes[m]);
        reach.push_back(std::sqrt(0.3 * d8 * d8 + e * e / 3.0));
        normalTurn.push_back(reach.back() / curvature[m]);
    }

    std::vector<gi::GroundTruthMesh> truthMeshes;
    for (const auto& instance : scene.instances)
        truthMeshes.push_back({instance.mesh, glm::dmat4(instance.world_T_model)});
    const gi::RayTracedGroundTruth rt = gi::RayTracedGroundTruth::create(truthMeshes);
    // LightSkin's truth: the same Embree scene in the core's disc model with disc-centre visibility.
    std::vector<gi::GroundTruthReceiver> receivers;
    for (int y = 0; y < kHeight; ++y)
        for (int x = 0; x < kWidth; ++x) {
            const cv::Vec4f pos = position.at<cv::Vec4f>(y, x);
            if (pos[3] <= 0.0f) continue;
            const cv::Vec4f nrm = normal.at<cv::Vec4f>(y, x);
            gi::GroundTruthReceiver r;
            r.position = dvec3(pos[0], pos[1], pos[2]);
            r.normal = glm::normalize(dvec3(nrm[0], nrm[1], nrm[2]));
            receivers.push_back(r);
        }
    std::vector<gi::GroundTruthResult> discTruth(receivers.size());
    gi::GroundTruthSettings truthSettings;
    truthSettings.discRings = truthSettings.discSectors = 1;
    truthSettings.threads = 2;
    rt.compute(vals, receivers, discTruth, truthSettings);

    const double s = double(settings.size) / kResolution;
    // Quadrature of eq. 3 with N stratified cells: only cells straddling a discontinuity are wrong,
    // each by at most 4 pi / N * L_max * max|kernel| (3/4), either sign. Discontinuities: the outlines
    // of the wall and the ceiling (each at most a full circle, 2 pi rad) and the sphere's silhouette
    // (at most 2 pi): n <= 2 * 6 pi / sqrt(4 pi / N) cells, sigma = w sqrt(n / 3); 5 sigma allowed.
    // L_max: the VAL map's radiance 0.5 x colour, red <= 0.5.
    const double cell = std::sqrt(4.0 * kPi / kRays);
    const double straddling = 2.0 * (6.0 * kPi) / cell;
    const double quadrature = 5.0 * (4.0 * kPi / kRays * 0.75 * 0.5) * std::sqrt(straddling / 3.0);
    double totalVolume = 0.0, totalL1 = 0.0, totalExact = 0.0, totalBudget = 0.0, totalBand = 0.0;
    int covered = 0, informative = 0;
    double lsTotal = 0.0, lsError = 0.0, lsAllowed = 0.0, discVisible = 0.0, discUnoccluded = 0.0, totalDisc = 0.0;
    std::vector<double> volumeE, volumeBound, lightSkinE, lightSkinBound, truthGap, pixelLight;
    for (int y = 0; y < kHeight; ++y)
        for (int x = 0; x < kWidth; ++x) {
            const cv::Vec4f pos = position.at<cv::Vec4f>(y, x);
            if (pos[3] <= 0.0f) continue;
            ++covered;
            const cv::Vec4f nrm = normal.at<cv::Vec4f>(y, x);
            const dvec3 p(pos[0], pos[1], pos[2]);
            const dvec3 n = glm::normalize(dvec3(nrm[0], nrm[1], nrm[2]));
            const double rho = double(albedo.at<cv::Vec4f>(y, x)[0]);
            ASSERT_GT(rho, 0.0);
            const IncidentL1 here = incident(rt, vals, p, n);
            // Voxel terms: the SH comes from voxel centres within s/2 (the shift along n) + sqrt(3)/2 s
            // (the trilinear cell) of p, and hit voxels enlarge silhouettes by up to sqrt(3) s: as if p
            // moved by (1/2 + sqrt 3 / 2 + sqrt 3) s. Bounded by |grad E1| times that; the gradient from
            // differences of the truth's E1 over s: central along the surface, forward along n (behind
            // the surface the truth is dark: a central difference there would measure the surface).
            const dvec3 t1 =
                glm::normalize(std::abs(n.z) < 0.9 ? glm::cross(n, dvec3(0, 0, 1)) : glm::cross(n, dvec3(1, 0, 0)));
            const dvec3 t2 = glm::cross(n, t1);
            double gradient2 = 0.0;
            for (const dvec3& t : {t1, t2}) {
                const double g =
                    (incident(rt, vals, p + s * t, n).l1 - incident(rt, vals, p - s * t, n).l1) / (2.0 * s);
                gradient2 += g * g;
            }
            const double gn = (incident(rt, vals, p + s * n, n).l1 - here.l1) / s;
            gradient2 += gn * gn;
            const double voxel = std::sqrt(gradient2) * (0.5 + 1.5 * std::sqrt(3.0)) * s;
            const double budget = voxel + quadrature + 1e-4 * here.l1; // + float rounding
            const double e = kPi * double(result.at<cv::Vec4f>(y, x)[0]) / rho;
            EXPECT_NEAR(e, here.l1, budget) << "pixel " << x << "," << y << " at " << p.x << "," << p.y << "," << p.z
                                            << " (voxel term " << voxel << ", quadrature " << quadrature << ")";
            EXPECT_NEAR(e, here.exact, budget + here.bandBound) << "pixel " << x << "," << y << ": against the truth";
            if (budget < here.l1) ++informative;
            // LightSkin against its truth (receivers are in the same order as this loop's pixels).
            const gi::GroundTruthResult& disc = discTruth[std::size_t(covered - 1)];
            const std::size_t mesh = p.z > 0.075 ? 0 : 1; // the sphere's bottom is at z = 0.15, the floor at 0
            const double eLs = kPi * double(lightSkinResult.at<cv::Vec4f>(y, x)[0]) / rho;
            ASSERT_TRUE(std::isfinite(eLs));
            const double fraction = lightSkinDiffuseBudget(vals, p, n, reach[mesh], normalTurn[mesh]);
            const double blockedHere = disc.unoccludedIrradiance.x - disc.irradiance.x;
            lsTotal += eLs;
            lsError += std::abs(eLs - disc.irradiance.x);
            lsAllowed += fraction * disc.irradiance.x;
            discVisible += disc.irradiance.x;
            discUnoccluded += disc.unoccludedIrradiance.x;
            totalDisc += disc.irradiance.x;
            volumeE.push_back(e);
            volumeBound.push_back(budget);
            lightSkinE.push_back(eLs);
            lightSkinBound.push_back(fraction * disc.irradiance.x + blockedHere);
            // The truths in between, computed exactly: the L1 band's (volumes) and the disc model's (LightSkin).
            truthGap.push_back(std::abs(here.l1 - disc.irradiance.x));
            pixelLight.push_back(here.exact);
            totalVolume += e;
            totalL1 += here.l1;
            totalExact += here.exact;
            totalBudget += budget;
            totalBand += here.bandBound;
        }
    ASSERT_GT(covered, kWidth * kHeight / 4);
    // Total light: the per-pixel bounds add up (triangle inequality).
    EXPECT_NEAR(totalVolume, totalL1, totalBudget);
    EXPECT_NEAR(totalVolume, totalExact, totalBudget + totalBand);
    EXPECT_GT(totalVolume, 0.0);
    // The budget must be informative: on most pixels and in total it is under the light itself, so
    // a volume that lost its light (all-zero output) fails there.
    EXPECT_GT(informative, covered / 2) << informative << " of " << covered << " pixels with budget < E1";
    EXPECT_LT(totalBudget, totalL1);

    // LightSkin against the truth, asserted as in gi_truth_gl_test: relative L1 within the summed
    // interpolation budget plus the blocked fraction B (occlusion on: no worse than no occlusion).
    ASSERT_EQ(std::size_t(covered), receivers.size());
    ASSERT_GT(discVisible, 0.0);
    const double blocked = 1.0 - discVisible / discUnoccluded;
    const double lsBudget = lsAllowed / discVisible + blocked;
    EXPECT_LE(lsError / discVisible, lsBudget) << "LightSkin relative L1 against the Embree truth";
    EXPECT_LT(lsBudget, 1.0) << "LightSkin's budget must be informative (an all-zero image has relative L1 1)";
    EXPECT_GT(lsTotal, 0.5 * discVisible) << "LightSkin must deliver the light, not zeros";
    // The two techniques against each other: |V - LS| <= |V - E1| + |E1 - E_disc| + |E_disc - LS|
    // (triangle inequality; E1 the truth's L1 irradiance the volumes approximate, E_disc the disc-model
    // truth LightSkin approximates, their gap computed, not bounded), in total and on every pixel
    // where both budgets are below the light (elsewhere a budget says nothing).
    const double totalAllowed = totalBudget + std::abs(totalL1 - totalDisc) + lsBudget * discVisible;
    EXPECT_NEAR(totalVolume, lsTotal, totalAllowed);
    int compared = 0;
    for (std::size_t i = 0; i < volumeE.size(); ++i) {
        if (!(volumeBound[i] < pixelLight[i] && lightSkinBound[i] < pixelLight[i])) continue;
        ++compared;
        EXPECT_NEAR(volumeE[i], lightSkinE[i], volumeBound[i] + lightSkinBound[i] + truthGap[i])
            << "pixel " << i << " of the covered ones: volumes against LightSkin";
    }
    EXPECT_GT(compared, covered / 4) << "the per-pixel comparison must cover a good part of the image";
    std::printf("LightSkin: total E %.4g, truth %.4g, relative L1 %.4f (budget %.4f, blocked %.4f); "
                "volumes vs LightSkin total %.4g vs %.4g (allowed %.4g), %d of %d pixels compared\n",
                lsTotal, discVisible, lsError / discVisible, lsBudget, blocked, totalVolume, lsTotal, totalAllowed,
                compared, covered);
    RecordProperty("total_volume", std::to_string(totalVolume));
    RecordProperty("total_lightskin", std::to_string(lsTotal));
    RecordProperty("total_truth", std::to_string(totalExact));
    RecordProperty("total_budget", std::to_string(totalBudget));
    std::printf("total E: volume %.4g, truth L1 %.4g, truth %.4g, budget %.4g (+ band %.4g), %d pixels, %d "
                "informative, quadrature %.3g\n",
                totalVolume, totalL1, totalExact, totalBudget, totalBand, covered, informative, quadrature);
}

} // namespace
} // namespace lightskin::test
