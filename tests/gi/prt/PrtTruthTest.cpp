// Multi-scale PRT against the Embree ground truth (gi::RayTracedGroundTruth) with multi-bounce: a Cornell-like
// box (red and green side walls, open top) lit by VALs above its opening. The truth is written independently
// of the PRT code: the first bounce from the VAL discs with exact visibility (stratified disc quadrature),
// then a radiosity iteration in which every fine triangle of the box is a Lambertian disc VAL of flux
// rho E A, evaluated by the same ray tracer, for `kTruthBounces` bounces plus the geometric tail bound.
#include "PrtScenes.h"

#include <lightskin/gi/prt/MultiscalePrt.h>
#include <lightskin/gi/reference/RayTracedGroundTruth.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

namespace lightskin::test {
namespace {

constexpr int kTruthBounces = 8;
const glm::vec3 kWhite(0.6f), kRed(0.7f, 0.15f, 0.15f), kGreen(0.15f, 0.7f, 0.15f);

prt::PrtScene cornellBox(int cells) {
    prt::PrtScene box = prt::insideBox(cells, kWhite, false);
    box.instances[1].material.diffuseAlbedo = kRed;   // x = 0
    box.instances[2].material.diffuseAlbedo = kGreen; // x = 1
    return box;
}

// 3 x 3 discs above the opening, facing down: every segment from inside the box to them leaves through the
// opening (the box is convex and the discs lie over its footprint), so the PRT's unoccluded first bounce is
// exact here and the comparison measures the transfer.
std::vector<gi::VirtualAreaLight> lightsAbove() {
    std::vector<gi::VirtualAreaLight> vals;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            gi::VirtualAreaLight v;
            v.position = {0.25f + 0.25f * float(i), 0.25f + 0.25f * float(j), 1.6f};
            v.normal = {0.0f, 0.0f, -1.0f};
            v.area = 0.01f;
            v.flux = glm::vec3(1.0f, 0.9f, 0.8f);
            vals.push_back(v);
        }
    return vals;
}

bool interior(const glm::vec3& p) { // >= 0.25 from the face's border (bounded connection kernel, see furnace)
    int near = 0;
    for (int k = 0; k < 3; ++k) near += std::min(p[k], 1.0f - p[k]) < 0.25f - 1e-5f ? 1 : 0;
    return near == 1;
}

// Indirect irradiance of bounces 2..kTruthBounces at `points` (bounce 1, from the VALs, is excluded: the PRT
// computes it with the same form factor directly), by radiosity on the triangles of a `cells` box.
struct TruthBounces {
    std::vector<glm::dvec3> sum;       // per point, bounces 2..kTruthBounces
    glm::dvec3 last{0.0}, before{0.0}; // the points' average of the last and the second-to-last bounce
};

TruthBounces truthBounces(int cells, const std::vector<gi::GroundTruthReceiver>& points) {
    const prt::PrtScene box = cornellBox(cells);
    std::vector<gi::GroundTruthMesh> meshes;
    for (const auto& instance : box.instances) meshes.push_back({instance.mesh, glm::dmat4(1.0)});
    const gi::RayTracedGroundTruth truth = gi::RayTracedGroundTruth::create(meshes);
    std::vector<gi::GroundTruthReceiver> patches;
    std::vector<double> areas;
    std::vector<glm::vec3> albedo;
    for (const auto& instance : box.instances)
        for (std::size_t t = 0; t < instance.mesh->triangleCount(); ++t) {
            const glm::vec3 a = instance.mesh->positions[instance.mesh->indices[3 * t]];
            const glm::vec3 b = instance.mesh->positions[instance.mesh->indices[3 * t + 1]];
            const glm::vec3 c = instance.mesh->positions[instance.mesh->indices[3 * t + 2]];
            gi::GroundTruthReceiver r;
            r.position = glm::dvec3(a + b + c) / 3.0;
            r.normal = glm::dvec3(instance.mesh->normals[0]);
            r.material = instance.material;
            patches.push_back(r);
            areas.push_back(0.5 * glm::length(glm::cross(glm::dvec3(b - a), glm::dvec3(c - a))));
            albedo.push_back(instance.material.diffuseAlbedo);
        }
    const std::vector<gi::VirtualAreaLight> vals = lightsAbove();
    std::vector<gi::GroundTruthResult> patchResult(patches.size()), pointResult(points.size());
    gi::GroundTruthSettings direct; // 8 x 16 stratified disc cells
    truth.compute(vals, patches, patchResult, direct);
    TruthBounces out;
    out.sum.assign(points.size(), glm::dvec3(0.0));
    gi::GroundTruthSettings patchSettings;
    patchSettings.discRings = 2; // patch discs near the receivers: a few cells each, not the centre's form factor
    patchSettings.discSectors = 4;
    std::vector<gi::VirtualAreaLight> emitters(patches.size());
    for (int bounce = 2; bounce <= kTruthBounces; ++bounce) {
        for (std::size_t p = 0; p < patches.size(); ++p) {
            emitters[p].position = glm::vec3(patches[p].position);
            emitters[p].normal = glm::vec3(patches[p].normal);
            emitters[p].area = float(areas[p]);
            emitters[p].flux = glm::vec3(glm::dvec3(albedo[p]) * patchResult[p].irradiance * areas[p]);
        }
        truth.compute(emitters, points, pointResult, patchSettings);
        out.before = out.last;
        out.last = glm::dvec3(0.0);
        for (std::size_t i = 0; i < points.size(); ++i) {
            out.sum[i] += pointResult[i].irradiance;
            out.last += pointResult[i].irradiance / double(points.size());
        }
        if (bounce < kTruthBounces) truth.compute(emitters, patches, patchResult, patchSettings);
    }
    return out;
}

TEST(PrtTruth, CornellBoxMultiBounceMatchesTheRayTracedRadiosity) {
    const prt::PrtScene box = cornellBox(4);
    gi::MultiscalePrtSettings settings;
    settings.entryPoints = 256;
    settings.walksPerEntry = 16;
    settings.maxBounces = 32;
    settings.clusters = 8;
    // D = 64 >= every cluster's size - 1: the PCA is exact here (its truncation error is PrtPca's subject), so
    // the comparison measures the transfer; the bound below stays in the budget for smaller D.
    settings.basisVectors = 64;
    settings.minConnectionDistance = 0.0f;
    const std::vector<gi::VirtualAreaLight> vals = lightsAbove();

    // PRT: 4 independent seeds; the bounce part E - E_val averaged over the interior exit points.
    constexpr int kReplicas = 4;
    std::vector<glm::dvec3> averages;
    glm::dvec3 pcaBound(0.0);
    std::vector<gi::GroundTruthReceiver> points;
    for (int r = 0; r < kReplicas; ++r) {
        settings.seed = std::uint32_t(77 + r);
        const gi::PrtData data = gi::precomputePrt(box.instances, settings);
        std::vector<glm::vec3> entry(data.entryCount()), exitAll(data.exitCount()), exitDirect(data.exitCount());
        gi::prtEntryIrradianceInto(data, vals, entry);
        gi::prtExitIrradianceInto(data, vals, entry, exitAll);
        const std::vector<glm::vec3> none(data.entryCount(), glm::vec3(0.0f));
        gi::prtExitIrradianceInto(data, vals, none, exitDirect);
        glm::dvec3 average(0.0);
        int n = 0;
        for (std::size_t x = 0; x < data.exitCount(); ++x) {
            if (!interior(data.exitPositions[x])) continue;
            average += glm::dvec3(exitAll[x] - exitDirect[x]);
            ++n;
            if (r == 0) {
                gi::GroundTruthReceiver p;
                p.position = glm::dvec3(data.exitPositions[x]);
                p.normal = glm::dvec3(data.exitNormals[x]);
                points.push_back(p);
            }
        }
        ASSERT_EQ(n, 45);
        averages.push_back(average / double(n));
        // PCA truncation at one exit point: |sum_e I_e (T_e - T~_e)[x]| <= ||I||_2 ||(T - T~)[., x]||_2, and the
        // column norm is at most the cluster's Frobenius error sqrt(sum of discarded sigma^2): per cluster, a
        // bound on every exit point and so on their average.
        if (r == 0) {
            for (std::uint32_t c = 0; c < data.clusterCount; ++c) {
                double discarded = 0.0, norm2[3] = {0.0, 0.0, 0.0};
                for (std::uint32_t k = data.singularValueOffsets[c] + std::uint32_t(data.basisVectors);
                     k < data.singularValueOffsets[c + 1]; ++k)
                    discarded += double(data.singularValues[k]) * double(data.singularValues[k]);
                for (std::size_t e = 0; e < data.entryCount(); ++e)
                    if (data.entryCluster[e] == c)
                        for (int ch = 0; ch < 3; ++ch) norm2[ch] += double(entry[e][ch]) * double(entry[e][ch]);
                for (int ch = 0; ch < 3; ++ch) pcaBound[ch] += std::sqrt(norm2[ch] * discarded);
            }
        }
    }
    glm::dvec3 mean(0.0), variance(0.0);
    for (const glm::dvec3& a : averages) mean += a / double(kReplicas);
    for (const glm::dvec3& a : averages) variance += (a - mean) * (a - mean) / double(kReplicas - 1);
    const glm::dvec3 standardError = glm::sqrt(variance / double(kReplicas));

    // Truth at two patch resolutions: their difference bounds the radiosity's own discretisation error
    // (first-order convergence in the patch size: the 8-cell error is about the 6-to-8 difference).
    const TruthBounces fine = truthBounces(8, points), coarse = truthBounces(6, points);
    glm::dvec3 truthFine(0.0), truthCoarse(0.0);
    for (std::size_t i = 0; i < points.size(); ++i) {
        truthFine += fine.sum[i] / double(points.size());
        truthCoarse += coarse.sum[i] / double(points.size());
    }
    // Bounces beyond kTruthBounces: the radiosity iteration converges to geometric decay with the ratio q of
    // its last two bounces, so the rest is last * q / (1 - q).
    const glm::dvec3 q = fine.last / fine.before;
    for (int c = 0; c < 3; ++c) {
        // t with 3 degrees of freedom: 5 standard errors fail an unbiased estimate with probability ~1.5 %;
        // deterministic seeds make the outcome reproducible.
        const double budget = 5.0 * standardError[c] + pcaBound[c] + std::abs(truthFine[c] - truthCoarse[c]) +
                              fine.last[c] * q[c] / (1.0 - q[c]);
        EXPECT_NEAR(mean[c], truthFine[c], budget)
            << "channel " << c << ": standard error " << standardError[c] << ", PCA bound " << pcaBound[c]
            << ", truth 6 vs 8 cells " << truthCoarse[c] << " / " << truthFine[c];
        EXPECT_LT(budget, 0.35 * truthFine[c]) << "a budget this wide would not detect a lost bounce";
        std::printf("channel %d: PRT %.5f +- %.5f, truth %.5f (6 cells %.5f), PCA bound %.2e, tail %.5f\n", c, mean[c],
                    standardError[c], truthFine[c], truthCoarse[c], pcaBound[c], fine.last[c] * q[c] / (1.0 - q[c]));
        EXPECT_GT(truthFine[c], 0.0);
        ASSERT_LT(q[c], 0.9) << "the bounces decay";
    }
    // Colour bleeding: the red wall makes the bounce light redder than the green-blue mean on the floor side.
    EXPECT_GT(mean.x / mean.z, 1.0);
}

} // namespace
} // namespace lightskin::test
