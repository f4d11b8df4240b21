// gi::ImperfectVolumes on the gather benchmarks' scene (lightskin::bench::gatherScene: a sphere 0.55 m
// above a 2.4 m floor, lit by a VAL map on a wall and the ceiling) against the Embree ground truth
// (gi::RayTracedGroundTruth) at every covered pixel, and in total. The budget of each pixel is derived
// from the voxel size and the ray count, as in ImperfectVolumesTruthGLTest: the position error of the
// SH (voxel centres around p' = p + s/2 n, silhouettes grown by the hit voxels), the quadrature error of
// eq. 3 at discontinuities, and against the exact irradiance also the L1 truncation of the cosine lobe.
#include "GlTestEnvironment.h"

#include <lightskin/bench/BenchScene.h>
#include <lightskin/gi/ImperfectVolumes.h>
#include <lightskin/gi/RayTracedGroundTruth.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/gl/Readback.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <numbers>

namespace lightskin::test {
namespace {

using glm::dvec3;
constexpr double kPi = std::numbers::pi;

struct IncidentL1 {
    double l1 = 0.0;        ///< integral of L_vis (1/4 + mu/2): the L1 irradiance of the truth's radiance
    double exact = 0.0;     ///< integral of L_vis max(0, mu): the irradiance
    double bandBound = 0.0; ///< integral of L_unoccluded |1/4 + mu/2 - max(0, mu)| >= |l1 - exact|
};

// Red channel. Small-disc solid angle A cos / d^2 per VAL (cells of <= 6 cm at >= 0.3 m from any
// receiver: relative error O((r / d)^2) < 1 %, below the voxel terms); visibility by Embree.
IncidentL1 incident(const gi::RayTracedGroundTruth& rt, std::span<const gi::VirtualAreaLight> vals, const dvec3& p,
                    const dvec3& n) {
    IncidentL1 out;
    for (const auto& val : vals) {
        const dvec3 y(val.position), toY = y - p;
        const double d2 = glm::dot(toY, toY), d = std::sqrt(d2);
        const dvec3 w = toY / d;
        const double cosJ = -glm::dot(dvec3(val.normal), w);
        if (cosJ <= 0.0) continue;
        const double radiance = double(val.flux.x) / (kPi * double(val.area));
        const double omegaL = radiance * double(val.area) * cosJ / d2;
        const double mu = glm::dot(n, w);
        out.bandBound += omegaL * std::abs(0.25 + 0.5 * mu - std::max(0.0, mu));
        if (rt.occluded(p + 1e-4 * n, y)) continue;
        out.l1 += omegaL * (0.25 + 0.5 * mu);
        out.exact += omegaL * std::max(0.0, mu);
    }
    return out;
}

using ImperfectVolumesBenchSceneGLTest = GlTest;

TEST_F(ImperfectVolumesBenchSceneGLTest, EveryPixelAndTheTotalLightWithinTheVoxelBudgetOfTheEmbreeTruth) {
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

    std::vector<gi::GroundTruthMesh> truthMeshes;
    for (const auto& instance : scene.instances)
        truthMeshes.push_back({instance.mesh, glm::dmat4(instance.world_T_model)});
    const gi::RayTracedGroundTruth rt = gi::RayTracedGroundTruth::create(truthMeshes);

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
    RecordProperty("total_volume", std::to_string(totalVolume));
    RecordProperty("total_truth", std::to_string(totalExact));
    RecordProperty("total_budget", std::to_string(totalBudget));
    std::printf("total E: volume %.4g, truth L1 %.4g, truth %.4g, budget %.4g (+ band %.4g), %d pixels, %d "
                "informative, quadrature %.3g\n",
                totalVolume, totalL1, totalExact, totalBudget, totalBand, covered, informative, quadrature);
}

} // namespace
} // namespace lightskin::test
