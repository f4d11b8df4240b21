// gi::ImperfectVolumes against the Embree ground truth (gi::RayTracedGroundTruth): receivers on a
// line under a virtual cube, lit by a ceiling of VALs; the cube shadows part of the line. The
// expected value is the L1 SH projection of the truth's incident radiance (every VAL with its
// Embree visibility), which is what a perfect voxelisation would give; the budget holds the
// errors the volume adds, each derived from the voxel size or the ray count. Separately, the
// truth's own irradiance lies within that budget plus the L1 band-limit bound.
#include "common/TestMeshes.h"
#include "GlTestEnvironment.h"
#include "VolumesTestSupport.h"

#include <lightskin/gi/volumes/ImperfectVolumes.h>
#include <lightskin/gi/reference/RayTracedGroundTruth.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/gl/Readback.h>

#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <numbers>

namespace lightskin::test {
namespace {

using glm::dvec3;
constexpr double kPi = std::numbers::pi;

// Small-disc solid angle per VAL: discs of 6 cm at >= 1.2 m, relative error O((r / d)^2) < 1e-3.
IncidentL1 incident(const gi::RayTracedGroundTruth& rt, std::span<const gi::VirtualAreaLight> vals, const dvec3& p,
                    const dvec3& n) {
    return incidentL1(rt, vals, p, n, 0.0);
}

using ImperfectVolumesTruthGLTest = GlTest;

TEST_F(ImperfectVolumesTruthGLTest, WithinTheVoxelAndRayBudgetOfTheEmbreeTruth) {
    // Grid: 2 m, 32^3, s = 6.25 cm. Ceiling: one VAL per voxel column at z = 1.53 (0.48 voxel into
    // its layer), radiance 1 downward. Cube: half-size 0.2 m at (0, 0, 0.75) (faces 0.2-0.8 voxel from
    // voxel faces), 256 points per triangle (~12 per voxel face: P(missed voxel) ~ e^-12).
    // Receivers: z = 0.2 (normal +z), x in [-0.6, 0.6], y = 0.03: under, beside and out of the shadow.
    constexpr int kResolution = 32, kRays = 4096, kReceivers = 25;
    const double s = 2.0 / kResolution;
    TriangleMesh cubeMesh = cube(0.2f);
    gi::UploadedMesh uploaded = gi::UploadedMesh::create(cubeMesh);
    gi::MeshInstance instance;
    instance.mesh = &cubeMesh;
    instance.gpu = uploaded.view();
    instance.world_T_model = glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 0.0f, 0.75f));
    std::vector<gi::VirtualAreaLight> vals;
    for (int i = 0; i < kResolution; ++i)
        for (int j = 0; j < kResolution; ++j) {
            const float area = float(s * s);
            vals.push_back({{float(-1.0 + (i + 0.5) * s), float(-1.0 + (j + 0.5) * s), 1.53f},
                            area,
                            {0, 0, -1},
                            0.0f,
                            glm::vec3(float(kPi) * area),
                            0.0f});
        }
    gl::Buffer valBuffer = gl::Buffer::create(GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)), vals.data());

    // A one-row G-buffer of the receivers, albedo 1: the output is E / pi.
    std::vector<glm::vec4> position(kReceivers), normal(kReceivers, glm::vec4(0, 0, 1, 0)),
        albedo(kReceivers, glm::vec4(1.0f));
    for (int r = 0; r < kReceivers; ++r) position[std::size_t(r)] = {-0.6f + 0.05f * float(r), 0.03f, 0.2f, 1.0f};
    const ReceiverRow receivers = ReceiverRow::create(position, normal, albedo);
    const gi::GBufferView gbuffer = receivers.view();
    const gl::Texture& output = receivers.output;

    gi::ImperfectVolumesSettings settings;
    settings.autoFit = false;
    settings.origin = glm::vec3(-1.0f, -1.0f, 0.0f);
    settings.size = 2.0f;
    settings.resolution = kResolution;
    settings.raysPerVoxel = kRays;
    settings.pointsPerTriangle = 256;
    auto technique = gi::ImperfectVolumes::create(settings);
    technique->prepare(std::span(&instance, 1));
    technique->render({valBuffer.id(), std::uint32_t(vals.size())}, std::span(&instance, 1), gbuffer, {}, output.id());
    cv::Mat result;
    gl::readTextureRgba32fInto(output, result);

    const gi::GroundTruthMesh occluder{&cubeMesh, glm::dmat4(instance.world_T_model)};
    const gi::RayTracedGroundTruth rt = gi::RayTracedGroundTruth::create(std::span(&occluder, 1));
    // Quadrature of eq. 3 with N stratified cells: only cells that straddle a discontinuity (the
    // ceiling's edge, at most a full circle, 2 pi rad; the cube's silhouette, perimeter <= 4 * 0.4 sqrt 2
    // m at >= 0.35 m, <= 6.5 rad) are wrong, each by at most 4 pi / N * L * max|kernel| (3/4), with
    // either sign: n <= 2 * 12.8 rad / sqrt(4 pi / N) cells, sigma = w sqrt(n / 3); 5 sigma allowed.
    const double cell = std::sqrt(4.0 * kPi / kRays);
    const double straddling = 2.0 * (2.0 * kPi + 6.5) / cell;
    const double quadrature = 5.0 * (4.0 * kPi / kRays * 0.75) * std::sqrt(straddling / 3.0);
    for (int r = 0; r < kReceivers; ++r) {
        const dvec3 p(position[std::size_t(r)]), n(0, 0, 1);
        const IncidentL1 here = incident(rt, vals, p, n);
        // Voxel terms: the SH comes from voxel centres within s/2 (the shift along n) + sqrt(3)/2 s
        // (the trilinear cell) of p, and the hit voxels enlarge silhouettes by up to sqrt(3) s: as if
        // p moved by (1/2 + sqrt 3 / 2 + sqrt 3) s. Bounded by |grad E1| times that, the gradient from
        // central differences of the truth's E1 at +- s.
        double gradient2 = 0.0;
        for (int axis = 0; axis < 3; ++axis) {
            dvec3 h(0.0);
            h[axis] = s;
            const double g = (incident(rt, vals, p + h, n).l1 - incident(rt, vals, p - h, n).l1) / (2.0 * s);
            gradient2 += g * g;
        }
        const double voxel = std::sqrt(gradient2) * (0.5 + 1.5 * std::sqrt(3.0)) * s;
        const double budget = voxel + quadrature + 1e-4 * here.l1; // + float rounding
        const double e = kPi * double(result.at<cv::Vec4f>(0, r)[0]);
        EXPECT_NEAR(e, here.l1, budget) << "receiver " << r << " at x = " << p.x << " (voxel term " << voxel
                                        << ", quadrature " << quadrature << ")";
        EXPECT_NEAR(e, here.exact, budget + here.bandBound) << "receiver " << r << ": against the truth";
    }
    // The scene must exercise the occlusion: the line crosses the shadow (truth darker under the cube).
    const IncidentL1 middle = incident(rt, vals, dvec3(0.0, 0.03, 0.2), dvec3(0, 0, 1));
    const IncidentL1 outside = incident(rt, vals, dvec3(-0.6, 0.03, 0.2), dvec3(0, 0, 1));
    EXPECT_LT(middle.exact, 0.8 * outside.exact);
}

} // namespace
} // namespace lightskin::test
