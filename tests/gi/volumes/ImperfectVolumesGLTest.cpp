// gi::ImperfectVolumes on the GPU against the double-precision reference
// (gi/reference/include/lightskin/gi/reference/ImperfectVolumesReference.h, written separately from the shaders): the
// same points (shared hash), the same grid and directions; occupancy, normals and every covered
// pixel compared, for one bounce, two bounces, ambient occlusion and with scene lights on the mesh
// points. Direct light of a mesh point against the closed form (point and spot lights, inside and
// outside the volume), shadowing by a cube map, VALs outside the grid clipped. Extremes: an empty
// volume, an all-occupied one, a 1^3 and a 128^3 volume (one ray), a 256^3 volume (the maximum) against
// the L1 AO of an open plane, stage times, bad settings.
#include "common/TestMeshes.h"
#include "ExpectError.h"
#include "GlTestEnvironment.h"
#include "VolumesTestSupport.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/volumes/ImperfectVolumes.h>
#include <lightskin/gi/reference/ImperfectVolumesReference.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/gl/Readback.h>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <numbers>
#include <ostream>
#include <string>

namespace lightskin::test {
namespace {

namespace vol = gi::reference::volumes;
using glm::dvec3;
constexpr double kPi = std::numbers::pi;

// A floor (0.3 voxel above a voxel face, so that no pixel's p' = p + s/2 n lies on a plane of
// voxel centres, where float and double could pick different neighbours) with a cube on it, in a
// fixed 16^3 grid of 0.1 m voxels (every face of the cube 0.2-0.5 voxel from a voxel face: points
// on a voxel face could fall on either side in float and double); a "real" wall of VALs at x = 0.65 facing -x and a
// ceiling of VALs at z = 1.25 facing down, each VAL at a voxel centre.
struct Scene {
    std::vector<TriangleMesh> meshes;
    std::vector<gi::UploadedMesh> gpu;
    std::vector<gi::MeshInstance> instances;
    std::vector<gi::VirtualAreaLight> vals;
    gl::Buffer valBuffer;
    gi::SimpleGBuffer gbuffer;
    gl::Texture output;
    glm::mat4 clip_T_world{1.0f};
    glm::vec3 eye{1.3f, -1.5f, 1.1f};
    static constexpr int kSize = 64;

    Scene() {
        meshes.push_back(planeGrid(1.5f, 3, 0.03f));
        meshes.push_back(cube(0.15f));
        instances.resize(2);
        instances[0].meshId = 0;
        instances[0].material.diffuseAlbedo = glm::vec3(0.5f, 0.6f, 0.7f);
        instances[1].meshId = 1;
        instances[1].world_T_model = glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 0.07f, 0.18f));
        instances[1].material.diffuseAlbedo = glm::vec3(0.8f, 0.6f, 0.4f);
        for (std::size_t i = 0; i < meshes.size(); ++i) {
            gpu.push_back(gi::UploadedMesh::create(meshes[i]));
            instances[i].mesh = &meshes[i];
            instances[i].gpu = gpu[i].view();
        }
        for (int a = 0; a < 15; ++a)
            for (int b = 0; b < 14; ++b) {
                const float u = -0.75f + 0.1f * float(a), v = -0.15f + 0.1f * float(b);
                vals.push_back({{0.65f, u, v}, 0.01f, {-1, 0, 0}, 0.0f, {0.03f, 0.015f, 0.008f}, 0.0f});
                vals.push_back({{u, v - 0.6f, 1.25f}, 0.01f, {0, 0, -1}, 0.0f, {0.01f, 0.01f, 0.012f}, 0.0f});
            }
        valBuffer = gl::Buffer::create(GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)), vals.data());
        gbuffer = gi::SimpleGBuffer::create(kSize, kSize);
        output = gl::Texture::create2D(GL_RGBA32F, kSize, kSize);
        clip_T_world = glm::perspective(0.9f, 1.0f, 0.01f, 100.0f) *
                       glm::lookAt(eye, glm::vec3(0.0f, 0.0f, 0.15f), glm::vec3(0, 0, 1));
        gbuffer.render(instances, clip_T_world);
    }
    gi::ValSetView valSet() const { return {valBuffer.id(), std::uint32_t(vals.size())}; }

    // A point light over the floor (1.1 m from its centre) and a spot light pointing down, unshadowed:
    // mesh-point radiance <= 0.8 / pi * 0.5 W/sr / (0.9 m)^2 = 0.16 W/(sr m^2), below the wall's.
    static std::vector<gi::VolumeLight> lights() {
        gi::VolumeLight point;
        point.position = {0.2f, -0.3f, 1.0f};
        point.intensity = {0.5f, 0.4f, 0.3f};
        gi::VolumeLight spot;
        spot.position = {-0.4f, 0.3f, 0.9f};
        spot.direction = {0.0f, 0.0f, -1.0f};
        spot.intensity = {0.3f, 0.3f, 0.4f};
        spot.cosInner = std::cos(0.5f);
        spot.cosOuter = std::cos(0.7f);
        return {point, spot};
    }
    static std::vector<vol::SceneLight> referenceLights() {
        std::vector<vol::SceneLight> out;
        for (const gi::VolumeLight& l : lights())
            out.push_back(
                {dvec3(l.position), dvec3(l.direction), dvec3(l.intensity), double(l.cosOuter), double(l.cosInner)});
        return out;
    }
};

gi::ImperfectVolumesSettings fixedGrid(int resolution, double size = 1.6) {
    gi::ImperfectVolumesSettings s;
    s.autoFit = false;
    s.origin = glm::vec3(-0.8f, -0.8f, -0.2f);
    s.size = float(size);
    s.resolution = resolution;
    s.pointsPerTriangle = 40;
    s.raysPerVoxel = 64;
    return s;
}

vol::Volume referenceVolume(const Scene& scene, const gi::ImperfectVolumesSettings& s, bool sceneLights = false) {
    vol::Volume volume(vol::Grid{dvec3(s.origin), double(s.size) / s.resolution, s.resolution});
    const std::vector<vol::SceneLight> lights = Scene::referenceLights();
    for (const auto& instance : scene.instances) {
        auto points = vol::sampleTriangles(*instance.mesh, glm::dmat4(instance.world_T_model), s.pointsPerTriangle,
                                           dvec3(instance.material.diffuseAlbedo), s.seed);
        if (sceneLights) vol::addDirectLight(points, lights);
        volume.inject(points);
    }
    std::vector<vol::SurfacePoint> points;
    for (const auto& val : scene.vals) points.push_back(vol::pointFromVal(val, dvec3(s.realAlbedo)));
    volume.inject(points);
    return volume;
}

struct Pixels {
    cv::Mat position, normal, albedo, output;
};

Pixels readPixels(const Scene& scene) {
    Pixels p;
    gl::readTextureRgba32fInto(scene.gbuffer.position(), p.position);
    gl::readTextureRgba32fInto(scene.gbuffer.normal(), p.normal);
    gl::Texture albedo = gl::Texture::wrap(scene.gbuffer.view().diffuseAlbedo, Scene::kSize, Scene::kSize);
    gl::readTextureRgba32fInto(albedo, p.albedo);
    (void)albedo.release(); // the G-buffer owns it
    gl::readTextureRgba32fInto(scene.output, p.output);
    return p;
}

struct Case {
    const char* name;
    int bounces;
    bool ambientOcclusion;
    bool sceneLights = false; ///< the mesh points carry the direct light of Scene::lights()
};
// gtest would print the case as raw bytes (a pointer), which ctest puts into the test's name.
void PrintTo(const Case& c, std::ostream* out) { *out << c.name; }

class ImperfectVolumesGLTest : public GlTest, public ::testing::WithParamInterface<Case> {};

TEST_P(ImperfectVolumesGLTest, MatchesTheDoubleReferenceAtEveryPixel) {
    Scene scene;
    gi::ImperfectVolumesSettings s = fixedGrid(16);
    s.bounces = GetParam().bounces;
    s.ambientOcclusion = GetParam().ambientOcclusion;
    s.aoRange = 0.45f;
    auto technique = gi::ImperfectVolumes::create(s);
    technique->prepare(scene.instances);
    if (GetParam().sceneLights) technique->setDirectLights(Scene::lights());
    technique->render(scene.valSet(), scene.instances, scene.gbuffer.view(), {scene.clip_T_world, scene.eye},
                      scene.output.id());

    const vol::Volume volume = referenceVolume(scene, s, GetParam().sceneLights);
    // Injection: the same occupied voxels and mean normals (float sums of <= ~100 unit vectors:
    // 1e-5 covers their rounding).
    const auto normals = technique->downloadVoxelNormals();
    int occupied = 0;
    for (std::size_t i = 0; i < normals.size(); ++i) {
        ASSERT_EQ(normals[i].w > 0.0f, volume.occupied(i)) << "voxel " << i;
        occupied += volume.occupied(i) ? 1 : 0;
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(normals[i][c], volume.normal(i)[c], 1e-5) << "voxel " << i;
    }
    EXPECT_GT(occupied, 200); // floor, cube, wall and ceiling
    if (GetParam().sceneLights) {
        // Direct light carried by the points: the same means of float terms of <= ~100 points
        // (1e-5 relative), and the lights must reach some voxels (> 0).
        const auto direct = technique->downloadVoxelDirect();
        double lit = 0.0;
        for (std::size_t i = 0; i < direct.size(); ++i)
            for (int c = 0; c < 3; ++c) {
                const double expected = volume.radiance(i)[c];
                EXPECT_NEAR(direct[i][c], expected, 1e-5 * std::max(expected, 1e-2)) << "voxel " << i;
                lit += expected;
            }
        EXPECT_GT(lit, 0.0);
    }

    const auto directions = vol::stratifiedDirections(s.raysPerVoxel);
    vol::MarchSettings march;
    march.visibility = s.ambientOcclusion;
    if (s.ambientOcclusion) march.maxDistance = double(s.aoRange);
    const auto incoming = vol::solve(volume, directions, s.bounces, march);

    const Pixels px = readPixels(scene);
    // Tolerance: float against double on the same inputs. The sums (64 rays, 8 voxels, 2 passes)
    // round to ~1e-5 relative; a ray whose sample point lies within float rounding of a voxel face
    // may enter another voxel, which changes E by at most one ray's share, 4 pi / N * L_max *
    // (pi Y00^2 + 2 pi / 3 Y1^2) = 3 pi / N * L_max: allowed on at most 1 % of the pixels.
    const double lMax = s.ambientOcclusion ? 1.0 : 1.0 / kPi * 3.0; // brightest exitant: wall 3 W/m^2 / pi
    const double oneRay = 3.0 * kPi / s.raysPerVoxel * lMax;
    int covered = 0, rayFlips = 0;
    double sum = 0.0;
    for (int y = 0; y < Scene::kSize; ++y)
        for (int x = 0; x < Scene::kSize; ++x) {
            const cv::Vec4f pos = px.position.at<cv::Vec4f>(y, x), out = px.output.at<cv::Vec4f>(y, x);
            if (pos[3] <= 0.0f) {
                EXPECT_EQ(out, cv::Vec4f(0, 0, 0, 0)) << x << "," << y;
                continue;
            }
            ++covered;
            const cv::Vec4f nrm = px.normal.at<cv::Vec4f>(y, x), alb = px.albedo.at<cv::Vec4f>(y, x);
            const dvec3 p(pos[0], pos[1], pos[2]);
            const dvec3 n = glm::normalize(dvec3(nrm[0], nrm[1], nrm[2]));
            const dvec3 e = vol::reconstructIrradiance(volume, incoming, p, n);
            for (int c = 0; c < 3; ++c) {
                const double expected = s.ambientOcclusion ? e.x / kPi : double(alb[c]) / kPi * e[c];
                const double scale = s.ambientOcclusion ? 1.0 : double(alb[c]) / kPi;
                const double error = std::abs(double(out[c]) - expected);
                sum += expected;
                if (error > 1e-5 * std::max(expected, 1e-3)) {
                    ++rayFlips;
                    EXPECT_LE(error, scale * oneRay) << x << "," << y << " channel " << c;
                }
            }
        }
    EXPECT_GT(covered, Scene::kSize * Scene::kSize / 4);
    EXPECT_LE(rayFlips, covered * 3 / 100) << "values differing by more than rounding";
    EXPECT_GT(sum, 0.0); // not all zero
}

INSTANTIATE_TEST_SUITE_P(Modes, ImperfectVolumesGLTest,
                         ::testing::Values(Case{"OneBounce", 1, false}, Case{"TwoBounces", 2, false},
                                           Case{"AmbientOcclusion", 1, true},
                                           Case{"SceneLightsTwoBounces", 2, false, true}),
                         [](const auto& param) { return std::string(param.param.name); });

using ImperfectVolumesExtremeGLTest = GlTest;

TEST_F(ImperfectVolumesExtremeGLTest, EmptyVolumeGivesExactlyZeroAndStagesAreTimed) {
    Scene scene;
    gi::ImperfectVolumesSettings s = fixedGrid(16);
    s.pointsPerTriangle = 0;
    auto technique = gi::ImperfectVolumes::create(s);
    technique->prepare(scene.instances);
    technique->render({}, scene.instances, scene.gbuffer.view(), {scene.clip_T_world, scene.eye}, scene.output.id());
    cv::Mat out;
    gl::readTextureRgba32fInto(scene.output, out);
    EXPECT_EQ(cv::countNonZero(out.reshape(1)), 0);
    std::vector<gl::StageTime> times;
    technique->lastStageTimes(times);
    ASSERT_EQ(times.size(), 3u);
    EXPECT_EQ(times[0].name, "inject");
    EXPECT_EQ(times[1].name, "ray march");
    EXPECT_EQ(times[2].name, "reconstruct");
}

TEST_F(ImperfectVolumesExtremeGLTest, AllOccupiedOneVoxelAndMaximumResolutionStayFiniteAndBounded) {
    Scene scene;
    // All occupied: one VAL per voxel centre of a 4^3 (and 1^3) grid around the scene, radiance 1,
    // normals up and down (they cancel: seen from every side). Every ray hits a neighbour or leaves,
    // so E <= pi and the output <= albedo. 128^3 with one ray: finite and >= 0.
    for (const int resolution : {4, 1, 128}) {
        gi::ImperfectVolumesSettings s = fixedGrid(resolution);
        s.raysPerVoxel = resolution == 128 ? 1 : 16;
        std::vector<gi::VirtualAreaLight> vals;
        if (resolution <= 4) {
            const float voxel = s.size / float(resolution);
            for (int i = 0; i < resolution * resolution * resolution; ++i) {
                const glm::vec3 c = s.origin + voxel * (glm::vec3(i % resolution, (i / resolution) % resolution,
                                                                  i / (resolution * resolution)) +
                                                        0.5f);
                for (float sign : {1.0f, -1.0f})
                    vals.push_back({c, 0.01f, {0, 0, sign}, 0.0f, glm::vec3(float(kPi * 0.01)), 0.0f});
            }
        } else {
            vals = scene.vals;
        }
        gl::Buffer buffer = gl::Buffer::create(GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)), vals.data());
        auto technique = gi::ImperfectVolumes::create(s);
        technique->prepare(scene.instances);
        technique->render({buffer.id(), std::uint32_t(vals.size())}, scene.instances, scene.gbuffer.view(),
                          {scene.clip_T_world, scene.eye}, scene.output.id());
        cv::Mat out;
        gl::readTextureRgba32fInto(scene.output, out);
        double maxValue = 0.0;
        for (int y = 0; y < out.rows; ++y)
            for (int x = 0; x < out.cols; ++x)
                for (int c = 0; c < 3; ++c) {
                    const float v = out.at<cv::Vec4f>(y, x)[c];
                    ASSERT_TRUE(std::isfinite(v) && v >= 0.0f) << resolution << ": " << x << "," << y;
                    maxValue = std::max(maxValue, double(v));
                }
        if (resolution == 1) {
            EXPECT_EQ(maxValue, 0.0); // its rays start outside its only voxel: nothing seen
        }
        if (resolution == 4) {
            // Radiance <= 1 everywhere, so E <= pi (1 + L1 ringing: <= 4/3 for a hemisphere step,
            // 1 + 1/2 * 3/4 bound used generously) and the output <= albedo (0.8) * E / pi.
            EXPECT_LE(maxValue, 0.8 * 1.5) << resolution;
            EXPECT_GT(maxValue, 0.0) << resolution;
        }
        if (resolution == 4) {
            const auto normals = technique->downloadVoxelNormals();
            for (const glm::vec4& n : normals) EXPECT_GT(n.w, 0.0f);
        }
    }
}

TEST_F(ImperfectVolumesExtremeGLTest, MaximumResolution256IsTheL1AmbientOcclusionOfAnOpenPlane) {
    // 256^3 voxels of 1 mm (sparse storage: every buffer far below 128 MiB). A floor of triangle points
    // fills the layer at z = 128.3 mm (2.1 M points, ~33 per voxel of its 250 x 250: a hole has
    // probability e^-33). Receivers on the floor's middle, normal +z, AO range 0.1 m. The free voxels
    // the reconstruction reads are one layer above the floor: every downward ray hits the floor layer
    // (its samples descend by <= s per step, the first at <= 0.37 s into the layer, and at |z| >= 1/8
    // (the lowest band of 64 stratified directions) it reaches the layer within 12 mm, inside the floor
    // and the range), every upward ray is open. So the GPU must give exactly the L1 projection of the
    // hemisphere step over the same directions, reconstructed with the cosine lobe (the reference's
    // projectSh and shIrradiance), to float rounding (1e-5; the exact hemisphere would give 1).
    TriangleMesh floor = planeGrid(0.25f, 64, 0.1283f);
    for (glm::vec3& p : floor.positions) p += glm::vec3(0.128f, 0.128f, 0.0f);
    gi::UploadedMesh uploaded = gi::UploadedMesh::create(floor);
    gi::MeshInstance instance;
    instance.mesh = &floor;
    instance.gpu = uploaded.view();
    gi::ImperfectVolumesSettings s;
    s.autoFit = false;
    s.origin = glm::vec3(0.0f);
    s.size = 0.256f;
    s.resolution = 256;
    s.raysPerVoxel = 64;
    s.pointsPerTriangle = 256;
    s.ambientOcclusion = true;
    s.aoRange = 0.1f;
    constexpr int kReceivers = 4;
    std::vector<glm::vec4> position(kReceivers), normal(kReceivers, glm::vec4(0, 0, 1, 0)),
        albedo(kReceivers, glm::vec4(1.0f));
    for (int r = 0; r < kReceivers; ++r)
        position[std::size_t(r)] = {0.1204f + 0.0051f * float(r), 0.1311f - 0.0037f * float(r), 0.1283f, 1.0f};
    const ReceiverRow receivers = ReceiverRow::create(position, normal, albedo);
    const gi::GBufferView gbuffer = receivers.view();
    const gl::Texture& output = receivers.output;
    auto technique = gi::ImperfectVolumes::create(s);
    technique->prepare(std::span(&instance, 1));
    technique->render({}, std::span(&instance, 1), gbuffer, {}, output.id());
    cv::Mat result;
    gl::readTextureRgba32fInto(output, result);

    // The floor layer: 250 x 250 voxels occupied (+ the edge's partial columns), within the slots.
    const glm::uvec2 counts = technique->downloadVoxelCounts();
    EXPECT_GE(counts.x, 250u * 250u);
    EXPECT_LE(counts.x, 252u * 252u);
    EXPECT_LE(counts.x, technique->slotCapacity());
    EXPECT_GT(counts.y, 0u);
    EXPECT_LE(counts.y, 8u * kReceivers);

    const auto directions = vol::stratifiedDirections(s.raysPerVoxel);
    const vol::Sh4 step = vol::projectSh([](const dvec3& d) { return d.z > 0.0 ? 1.0 : 0.0; }, directions);
    const double expected = vol::shIrradiance(step, dvec3(0, 0, 1)) / kPi;
    EXPECT_NEAR(expected, 1.0, 0.05); // the quadrature of a hemisphere step with 64 directions
    for (int r = 0; r < kReceivers; ++r)
        EXPECT_NEAR(double(result.at<cv::Vec4f>(0, r)[0]), expected, 1e-5) << "receiver " << r;
}

TEST_F(ImperfectVolumesExtremeGLTest, VoxelsBeyondTheSlotsAreCountedAndWarnedOncePerRun) {
    // The 256^3 overflow (more occupied voxels than one storage buffer's ~2.8 M slots) provoked
    // cheaply: a 16^3 grid capped at 5 slots. A floor layer at z = 0.1283 fills one layer of 16 x 16
    // voxels (256 > 5 requested), 4 receivers ask for their 8 voxels each (> 5). Both counters must
    // report exactly requested - capacity as dropped, frame after frame, with one warning in all.
    TriangleMesh floor = planeGrid(0.25f, 16, 0.1283f);
    for (glm::vec3& p : floor.positions) p += glm::vec3(0.128f, 0.128f, 0.0f);
    gi::UploadedMesh uploaded = gi::UploadedMesh::create(floor);
    gi::MeshInstance instance;
    instance.mesh = &floor;
    instance.gpu = uploaded.view();
    gi::ImperfectVolumesSettings s;
    s.autoFit = false;
    s.origin = glm::vec3(0.0f);
    s.size = 0.256f;
    s.resolution = 16;
    s.raysPerVoxel = 16;
    s.pointsPerTriangle = 16;
    s.maxSlots = 5;
    constexpr int kReceivers = 4;
    std::vector<glm::vec4> position(kReceivers), normal(kReceivers, glm::vec4(0, 0, 1, 0)),
        albedo(kReceivers, glm::vec4(1.0f));
    for (int r = 0; r < kReceivers; ++r) position[std::size_t(r)] = {0.03f + 0.05f * float(r), 0.1311f, 0.1283f, 1.0f};
    const ReceiverRow receivers = ReceiverRow::create(position, normal, albedo);
    const gi::GBufferView gbuffer = receivers.view();
    const gl::Texture& output = receivers.output;
    auto technique = gi::ImperfectVolumes::create(s);
    ASSERT_EQ(technique->slotCapacity(), 5u);
    technique->prepare(std::span(&instance, 1));
    testing::internal::CaptureStderr();
    for (int frame = 0; frame < 3; ++frame) {
        technique->render({}, std::span(&instance, 1), gbuffer, {}, output.id());
        const glm::uvec2 requested = technique->downloadVoxelCounts();
        const glm::uvec2 dropped = technique->lastDroppedVoxels();
        EXPECT_GE(requested.x, 16u * 16u) << "frame " << frame;
        EXPECT_GT(requested.y, 5u) << "frame " << frame;
        EXPECT_EQ(dropped.x, requested.x - 5u) << "frame " << frame;
        EXPECT_EQ(dropped.y, requested.y - 5u) << "frame " << frame;
    }
    const std::string log = testing::internal::GetCapturedStderr();
    std::size_t warnings = 0;
    for (std::size_t at = log.find("voxels dropped"); at != std::string::npos; at = log.find("voxels dropped", at + 1))
        ++warnings;
    EXPECT_EQ(warnings, 1u) << log;
    EXPECT_NE(log.find("smaller gi.imperfectVolumes resolution"), std::string::npos) << log;
    cv::Mat result;
    gl::readTextureRgba32fInto(output, result);
    for (int r = 0; r < kReceivers; ++r) EXPECT_TRUE(std::isfinite(result.at<cv::Vec4f>(0, r)[0])) << "receiver " << r;

    // Without the cap the grid has a slot for every voxel: nothing dropped, no read-back needed.
    s.maxSlots = 0;
    auto uncapped = gi::ImperfectVolumes::create(s);
    uncapped->prepare(std::span(&instance, 1));
    uncapped->render({}, std::span(&instance, 1), gbuffer, {}, output.id());
    EXPECT_EQ(uncapped->slotCapacity(), 16u * 16u * 16u);
    EXPECT_EQ(uncapped->lastDroppedVoxels(), glm::uvec2(0u));
}

TEST_F(ImperfectVolumesExtremeGLTest, TemporalBlendIsAnExponentialAverageOfTheFrames) {
    // Static scene, h = 1/2: frames 1 and 2 equal the unblended output (frame 1 has no history,
    // frame 2 blends two equal frames); then every VAL's flux doubles: the light is linear in it, so
    // frame 3 = (1 - h) 2 x + h x = 1.5 x. Tolerance: float rounding of the sums, 1e-5 relative.
    Scene scene;
    gi::ImperfectVolumesSettings s = fixedGrid(16);
    auto plain = gi::ImperfectVolumes::create(s);
    s.temporalBlend = 0.5f;
    auto blended = gi::ImperfectVolumes::create(s);
    plain->prepare(scene.instances);
    blended->prepare(scene.instances);
    const gi::ViewParameters view{scene.clip_T_world, scene.eye};
    cv::Mat reference, frame;
    plain->render(scene.valSet(), scene.instances, scene.gbuffer.view(), view, scene.output.id());
    gl::readTextureRgba32fInto(scene.output, reference);
    ASSERT_GT(cv::norm(reference), 0.0);
    const auto expectScaled = [&](double factor, const char* what) {
        gl::readTextureRgba32fInto(scene.output, frame);
        double worst = 0.0;
        for (int y = 0; y < frame.rows; ++y)
            for (int x = 0; x < frame.cols; ++x)
                for (int c = 0; c < 3; ++c) {
                    const double expected = factor * double(reference.at<cv::Vec4f>(y, x)[c]);
                    worst = std::max(worst, std::abs(double(frame.at<cv::Vec4f>(y, x)[c]) - expected) /
                                                std::max(expected, 1e-3));
                }
        EXPECT_LT(worst, 1e-5) << what;
    };
    for (int f = 1; f <= 2; ++f) {
        blended->render(scene.valSet(), scene.instances, scene.gbuffer.view(), view, scene.output.id());
        expectScaled(1.0, f == 1 ? "frame 1" : "frame 2");
    }
    std::vector<gi::VirtualAreaLight> brighter = scene.vals;
    for (auto& val : brighter) val.flux *= 2.0f;
    gl::Buffer buffer = gl::Buffer::create(GLsizeiptr(brighter.size() * sizeof(gi::VirtualAreaLight)), brighter.data());
    blended->render({buffer.id(), std::uint32_t(brighter.size())}, scene.instances, scene.gbuffer.view(), view,
                    scene.output.id());
    expectScaled(1.5, "frame 3 after the light doubled");
}

// One small triangle (edge 1 mm, normal +z) in a fixed 4^3 grid of [-0.1, 0.1]^3: its points all
// fall in one voxel, whose direct radiance is then the mean of albedo / pi * E over the points.
struct OneTriangle {
    TriangleMesh mesh;
    gi::UploadedMesh gpu;
    gi::MeshInstance instance;
    gi::SimpleGBuffer gbuffer = gi::SimpleGBuffer::create(4, 4);
    gl::Texture output = gl::Texture::create2D(GL_RGBA32F, 4, 4);
    static constexpr float kAlbedo = 0.6f;

    OneTriangle() {
        mesh.positions = {{0.03f, 0.03f, 0.03f}, {0.031f, 0.03f, 0.03f}, {0.03f, 0.031f, 0.03f}};
        mesh.normals.assign(3, glm::vec3(0.0f, 0.0f, 1.0f));
        mesh.indices = {0, 1, 2};
        gpu = gi::UploadedMesh::create(mesh);
        instance.mesh = &mesh;
        instance.gpu = gpu.view();
        instance.material.diffuseAlbedo = glm::vec3(kAlbedo);
    }
    static gi::ImperfectVolumesSettings settings() {
        gi::ImperfectVolumesSettings s;
        s.autoFit = false;
        s.origin = glm::vec3(-0.1f);
        s.size = 0.2f;
        s.resolution = 4;
        s.raysPerVoxel = 4;
        s.pointsPerTriangle = 16;
        return s;
    }
    // The direct radiance of the triangle's voxel: (0.13 / 0.05) = 2.6, voxel (2, 2, 2), index 42.
    glm::vec4 voxelDirect(std::span<const gi::VolumeLight> lights) {
        auto technique = gi::ImperfectVolumes::create(settings());
        technique->prepare(std::span(&instance, 1));
        technique->setDirectLights(lights);
        technique->render({}, std::span(&instance, 1), gbuffer.view(), {}, output.id());
        const auto direct = technique->downloadVoxelDirect();
        const auto normals = technique->downloadVoxelNormals();
        EXPECT_GT(normals[42].w, 0.0f) << "the triangle's voxel";
        return direct[42];
    }
};

using ImperfectVolumesDirectLightGLTest = GlTest;

TEST_F(ImperfectVolumesDirectLightGLTest, AMeshPointFacingALightGetsTheClosedFormIrradianceTimesAlbedo) {
    // Closed form: a point light of power P at distance d straight above a point whose normal faces
    // it: E = P / (4 pi d^2), L = rho / pi * E. The light sits 1 m above, outside the 0.2 m volume
    // (lights act from anywhere). Tolerance: the points lie within r = 1.5 mm of the axis point, so
    // cos / d^2 differs from 1 / d^2 by <= 1.5 (r / d)^2 = 3.4e-6 relative; plus float rounding of
    // the sums (1e-6): 1e-5 relative.
    OneTriangle t;
    const double power = 20.0;
    gi::VolumeLight light;
    light.position = {0.0303f, 0.0303f, 1.03f};
    light.intensity = glm::vec3(float(power / (4.0 * kPi)));
    const double d = double(light.position.z) - double(0.03f); // the triangle's plane; ~1 m
    const double expected = double(OneTriangle::kAlbedo) / kPi * power / (4.0 * kPi * d * d);
    const glm::vec4 point = t.voxelDirect(std::span(&light, 1));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(point[c], expected, 1e-5 * expected) << "channel " << c;

    // The double reference's direct light gives the same closed form (it is what the other tests
    // compare the volume with): 1e-12 relative, exact arithmetic up to rounding.
    const vol::SceneLight reference{dvec3(light.position), dvec3(0, 0, -1), dvec3(light.intensity), -2.0, -1.0};
    const dvec3 e = vol::directIrradiance(dvec3(light.position.x, light.position.y, double(0.03f)), dvec3(0, 0, 1),
                                          std::span(&reference, 1));
    EXPECT_NEAR(e.x, double(light.intensity.x) / (d * d), 1e-12 * e.x); // I = P / (4 pi), rounded to float

    // A spot light on the same axis: full intensity inside its inner cone (same value), none
    // outside its outer cone (exactly 0), and half the smoothstep at the middle of its falloff
    // (cone = 1/2 where t = 1/2; the points' angles spread by 1.5e-3 rad around it, which moves
    // smoothstep by <= 1.5 * 1.5e-3 / (falloff width) relative: 1e-2 with a 0.2 rad falloff).
    gi::VolumeLight spot = light;
    spot.direction = {0.0f, 0.0f, -1.0f};
    spot.cosInner = std::cos(0.3f);
    spot.cosOuter = std::cos(0.5f);
    const glm::vec4 inside = t.voxelDirect(std::span(&spot, 1));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(inside[c], expected, 1e-5 * expected);
    spot.direction = glm::normalize(glm::vec3(std::sin(0.6f), 0.0f, -std::cos(0.6f)));
    EXPECT_EQ(t.voxelDirect(std::span(&spot, 1)), glm::vec4(0.0f)) << "outside the outer cone";
    // Axis tilted by 0.4 rad: the points are at the middle of the falloff, angle 0.4 = (0.3 + 0.5) / 2
    // in angle; smoothstep is over the cosine: t = (cos 0.4 - cos 0.5) / (cos 0.3 - cos 0.5).
    spot.direction = glm::normalize(glm::vec3(std::sin(0.4f), 0.0f, -std::cos(0.4f)));
    const double tc = (std::cos(0.4) - std::cos(0.5)) / (std::cos(0.3) - std::cos(0.5));
    const double cone = tc * tc * (3.0 - 2.0 * tc);
    const glm::vec4 falloff = t.voxelDirect(std::span(&spot, 1));
    EXPECT_NEAR(falloff.x, cone * expected, 1e-2 * cone * expected);
}

TEST_F(ImperfectVolumesDirectLightGLTest, ShadowCubeMapDarkensThePointsBehindTheOccluderAsTheRendererDoes) {
    // A floor grid (1.2 m, z = 0.03) under a point light at 1 m; the shadow map says an occluder
    // sits 1.1 m from the light in every direction: the renderer's test (distance - (0.01 + 0.02
    // distance) > stored) shadows the floor points farther than 1.1 / 0.98 + ... from the light,
    // i.e. beyond ~0.48 m from the spot below it. Every voxel's mean direct radiance against the
    // reference with the same test (1e-5 relative: float sums), and both lit and shadowed voxels exist.
    TriangleMesh floor = planeGrid(1.2f, 12, 0.03f);
    gi::UploadedMesh uploaded = gi::UploadedMesh::create(floor);
    gi::MeshInstance instance;
    instance.mesh = &floor;
    instance.gpu = uploaded.view();
    instance.material.diffuseAlbedo = glm::vec3(0.5f);
    gi::ImperfectVolumesSettings s;
    s.autoFit = false;
    s.origin = glm::vec3(-0.8f, -0.8f, -0.2f);
    s.size = 1.6f;
    s.resolution = 16;
    s.raysPerVoxel = 4;
    s.pointsPerTriangle = 8;
    constexpr float kStored = 1.1f;
    constexpr int kFace = 8;
    GLuint cubes = 0;
    glCreateTextures(GL_TEXTURE_CUBE_MAP_ARRAY, 1, &cubes);
    gl::Texture shadow = gl::Texture::wrap(cubes, kFace, kFace);
    glTextureStorage3D(cubes, 1, GL_R32F, kFace, kFace, 6);
    glTextureParameteri(cubes, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(cubes, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    const std::vector<float> stored(std::size_t(kFace * kFace * 6), kStored);
    glTextureSubImage3D(cubes, 0, 0, 0, 0, kFace, kFace, 6, GL_RED, GL_FLOAT, stored.data());
    gi::VolumeLight light;
    light.position = {0.05f, -0.05f, 1.03f};
    light.intensity = glm::vec3(1.0f);
    light.castsShadows = true;

    gi::SimpleGBuffer gbuffer = gi::SimpleGBuffer::create(4, 4);
    gl::Texture output = gl::Texture::create2D(GL_RGBA32F, 4, 4);
    auto technique = gi::ImperfectVolumes::create(s);
    technique->prepare(std::span(&instance, 1));
    technique->setDirectLights(std::span(&light, 1), shadow.id());
    technique->render({}, std::span(&instance, 1), gbuffer.view(), {}, output.id());
    const auto direct = technique->downloadVoxelDirect();

    vol::Volume volume(vol::Grid{dvec3(s.origin), double(s.size) / s.resolution, s.resolution});
    auto points = vol::sampleTriangles(floor, glm::dmat4(1.0), s.pointsPerTriangle, dvec3(0.5), s.seed);
    const vol::SceneLight reference{dvec3(light.position), dvec3(0, 0, -1), dvec3(light.intensity), -2.0, -1.0};
    vol::addDirectLight(points, std::span(&reference, 1), [&](std::size_t, const dvec3& p) {
        const double dist = glm::length(p - reference.position);
        return !(dist - (0.01 + 0.02 * dist) > double(kStored));
    });
    volume.inject(points);
    int lit = 0, dark = 0;
    for (std::size_t i = 0; i < direct.size(); ++i) {
        if (!volume.occupied(i)) continue;
        const double expected = volume.radiance(i).x;
        EXPECT_NEAR(direct[i].x, expected, 1e-5 * std::max(expected, 1e-2)) << "voxel " << i;
        (expected > 0.0 ? lit : dark) += 1;
    }
    EXPECT_GT(lit, 10);
    EXPECT_GT(dark, 10);

    // Without the shadow map the same light reaches every floor voxel.
    technique->setDirectLights(std::span(&light, 1));
    technique->render({}, std::span(&instance, 1), gbuffer.view(), {}, output.id());
    const auto unshadowed = technique->downloadVoxelDirect();
    for (std::size_t i = 0; i < unshadowed.size(); ++i)
        if (volume.occupied(i)) {
            EXPECT_GT(unshadowed[i].x, 0.0f) << "voxel " << i;
        }
}

TEST_F(ImperfectVolumesDirectLightGLTest, ValsOutsideTheGridAreClippedAndMoreThanFourLightsAreRefused) {
    // Defined behaviour of light outside the volume: VAL points outside the grid are dropped, so a
    // bright wall of VALs beyond it changes no pixel (exact equality: the same float operations).
    Scene scene;
    const gi::ImperfectVolumesSettings s = fixedGrid(16);
    auto technique = gi::ImperfectVolumes::create(s);
    technique->prepare(scene.instances);
    const gi::ViewParameters view{scene.clip_T_world, scene.eye};
    technique->render(scene.valSet(), scene.instances, scene.gbuffer.view(), view, scene.output.id());
    cv::Mat inside, withOutside;
    gl::readTextureRgba32fInto(scene.output, inside);
    ASSERT_GT(cv::norm(inside), 0.0);
    std::vector<gi::VirtualAreaLight> vals = scene.vals;
    for (int a = 0; a < 10; ++a) // x = 0.85 > grid's 0.8, facing the scene, 100x brighter than the wall
        vals.push_back({{0.85f, -0.5f + 0.1f * float(a), 0.2f}, 0.01f, {-1, 0, 0}, 0.0f, glm::vec3(3.0f), 0.0f});
    gl::Buffer buffer = gl::Buffer::create(GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)), vals.data());
    technique->render({buffer.id(), std::uint32_t(vals.size())}, scene.instances, scene.gbuffer.view(), view,
                      scene.output.id());
    gl::readTextureRgba32fInto(scene.output, withOutside);
    EXPECT_EQ(cv::norm(inside, withOutside, cv::NORM_INF), 0.0);

    const std::vector<gi::VolumeLight> five(5);
    expectError([&] { technique->setDirectLights(five); },
                {"imperfect volumes", std::nullopt, "5 lights: at most 4 carry direct light into the volume"});
}

using ImperfectVolumesVisibleEffectsGLTest = GlTest;

// Floor pixels of the Scene (normal +z, on the floor plane z = 0.03) by their horizontal distance
// to the cube's footprint [-0.15, 0.15] x [-0.08, 0.22].
struct FloorPixel {
    int x, y;
    double distanceToCube;
};
std::vector<FloorPixel> floorPixels(const Pixels& px) {
    std::vector<FloorPixel> out;
    for (int y = 0; y < Scene::kSize; ++y)
        for (int x = 0; x < Scene::kSize; ++x) {
            const cv::Vec4f pos = px.position.at<cv::Vec4f>(y, x), n = px.normal.at<cv::Vec4f>(y, x);
            if (pos[3] <= 0.0f || n[2] < 0.99f || std::abs(pos[2] - 0.03f) > 1e-3f) continue;
            const double dx = std::max({-0.15 - double(pos[0]), double(pos[0]) - 0.15, 0.0});
            const double dy = std::max({-0.08 - double(pos[1]), double(pos[1]) - 0.22, 0.0});
            out.push_back({x, y, std::hypot(dx, dy)});
        }
    return out;
}

TEST_F(ImperfectVolumesVisibleEffectsGLTest, AmbientOcclusionDarkensTheContactRegion) {
    // Floor and cube only (no VALs), AO range 0.45 m. Far from the cube (>= 0.55 m: range plus the
    // half-voxel shift of p') the floor sees its open hemisphere: L1 AO of a hemisphere step is
    // exactly 1 (integral of 1/4 + mu/2 over mu in [0, 1] times 2 pi = pi), more where rays below the
    // horizon leave past the floor's edge (the kernel is positive down to mu = -1/2). Within 0.1 m of
    // the cube, the cube's side (0.3 m wide, 0.3 m high) covers a form factor >= 0.19 (a point at
    // x = 0.15 m from the centre line of a perpendicular 2w x H rectangle: (1/pi)[atan(w/x) -
    // x/sqrt(x^2+H^2) atan(w/sqrt(x^2+H^2))] with w = 0.15, H = 0.3), so the true AO <= 0.81 there;
    // allowed 0.9 for the voxel terms (the SH comes from centres up to (1/2 + sqrt 3 / 2) s = 0.14 m
    // from p, where the form factor falls to ~0.1).
    Scene scene;
    gi::ImperfectVolumesSettings s = fixedGrid(16);
    s.ambientOcclusion = true;
    s.aoRange = 0.45f;
    auto technique = gi::ImperfectVolumes::create(s);
    technique->prepare(scene.instances);
    technique->render({}, scene.instances, scene.gbuffer.view(), {scene.clip_T_world, scene.eye}, scene.output.id());
    const Pixels px = readPixels(scene);
    double contactSum = 0.0, farMin = 2.0;
    int contact = 0, far = 0;
    for (const FloorPixel& f : floorPixels(px)) {
        const double ao = double(px.output.at<cv::Vec4f>(f.y, f.x)[0]);
        if (f.distanceToCube <= 0.1) {
            contactSum += ao;
            ++contact;
        } else if (f.distanceToCube >= 0.55) {
            farMin = std::min(farMin, ao);
            ++far;
        }
    }
    ASSERT_GT(contact, 10);
    ASSERT_GT(far, 10);
    EXPECT_GE(farMin, 1.0 - 1e-4); // float rounding of the SH sums (64 rays)
    EXPECT_LT(contactSum / contact, 0.9);
}

TEST_F(ImperfectVolumesVisibleEffectsGLTest, SecondBounceAddsLightInTheConcaveCorner) {
    // The second pass re-emits albedo / pi * E at every occupied voxel. That is not more light at
    // every pixel: the L1 cosine kernel 1/4 + mu/2 is negative below mu = -1/2, where a receiver's
    // voxels see the re-emission of its own surface underneath (the floor), which lowers E on open
    // floor. In the concave corner (floor within 0.1 m of the cube) the cube's lit faces re-emit
    // toward the floor from the front (mu > 0): there the second bounce must add light, required
    // here 1e-3 relative (float rounding of the sums is 1e-5).
    Scene scene;
    gi::ImperfectVolumesSettings s = fixedGrid(16);
    cv::Mat one, two;
    for (int bounces : {1, 2}) {
        s.bounces = bounces;
        auto technique = gi::ImperfectVolumes::create(s);
        technique->prepare(scene.instances);
        technique->render(scene.valSet(), scene.instances, scene.gbuffer.view(), {scene.clip_T_world, scene.eye},
                          scene.output.id());
        gl::readTextureRgba32fInto(scene.output, bounces == 1 ? one : two);
    }
    const Pixels px = readPixels(scene);
    double oneSum = 0.0, twoSum = 0.0;
    int contact = 0;
    for (const FloorPixel& f : floorPixels(px))
        if (f.distanceToCube <= 0.1) {
            oneSum += double(one.at<cv::Vec4f>(f.y, f.x)[0]);
            twoSum += double(two.at<cv::Vec4f>(f.y, f.x)[0]);
            ++contact;
        }
    ASSERT_GT(contact, 10);
    EXPECT_GT(oneSum, 0.0);
    EXPECT_GT(twoSum, oneSum * (1.0 + 1e-3)) << "one bounce " << oneSum << ", two " << twoSum;
}

using ImperfectVolumesSettingsTest = GlTest;

TEST_F(ImperfectVolumesSettingsTest, BadSettingsNameTheField) {
    gi::ImperfectVolumesSettings s;
    s.resolution = 0;
    expectError([&] { gi::validate(s); }, {"gi.imperfectVolumes", std::nullopt, "resolution = 0 is outside [1, 256]"});
    s = {};
    s.resolution = 257;
    expectError([&] { gi::validate(s); },
                {"gi.imperfectVolumes", std::nullopt, "resolution = 257 is outside [1, 256]"});
    s = {};
    s.bounces = 5;
    expectError([&] { gi::validate(s); }, {"gi.imperfectVolumes", std::nullopt, "bounces = 5 is outside [1, 4]"});
    s = {};
    s.raysPerVoxel = 0;
    expectError([&] { gi::ImperfectVolumes::create(s); }, {"gi.imperfectVolumes", std::nullopt, "raysPerVoxel = 0"});
    s = {};
    s.aoRange = -1.0f;
    expectError([&] { gi::validate(s); }, {"gi.imperfectVolumes", std::nullopt, "aoRange"});
    s = {};
    s.realAlbedo = 2.0f;
    expectError([&] { gi::validate(s); }, {"gi.imperfectVolumes", std::nullopt, "realAlbedo must be <= 1"});
    s = {};
    s.temporalBlend = 1.0f;
    expectError([&] { gi::validate(s); }, {"gi.imperfectVolumes", std::nullopt, "temporalBlend = 1.0"});
}

} // namespace
} // namespace lightskin::test
