// The brute force's black pixel on the PCL Kinect TIFF (objects sunk 1 cm): a mesh file that
// lists a triangle twice, the copy wound the other way (bun_zipper_res4.ply holds 39 such copies), got
// generated vertex normals turned by up to ~170 degrees at the copy's corners; the G-buffer interpolates
// them, and under light from near a receiver's horizon the brute force (and LightSkin's per-pixel
// shading, which uses the same G-buffer normal) turned lit pixels black. Here the whole chain runs:
// loadModel -> G-buffer -> brute force, on a roof with a 13 degree crease (the bunny's at that pixel)
// whose reversed copy sits at the ridge and is listed last (so assimp's normal of its shared corners is
// that copy's), lit by one VAL disc.
//
// Reference, independent of the code under test: eq. 3-4 written out in double with the roof's own
// face normal at the pixel's G-buffer position (the plane x < 1 or x > 1). Why a per-pixel bound and not
// equality: generated normals are smooth within the crease angle, so the shading normal n_s of any
// pixel lies within delta = 13 degrees of its face normal n_f (every vertex normal averages face normals
// of adjacent faces, all within 13 degrees of each other, and the interpolant of three normals in a
// cone stays in the cone). With theta the angle between the direction to the VAL and n_f,
// cos(theta_i) with n_s lies in [cos(theta + delta), cos(max(theta - delta, 0))]; the disc's own
// factors (cos(theta_j), r^2 + d^2) do not depend on the normal. So E_bf / E_face must lie in
// [cos(theta + delta) / cos(theta), cos(max(theta - delta, 0)) / cos(theta)], widened by 1e-4 relative
// for float (position, normal and the 1/(r^2 + d^2) in single precision: a few ulp, < 1e-5).
#include "GlTestEnvironment.h"
#include "TestPaths.h"

#include <lightskin/gi/bruteforce/BruteForceIllumination.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gi/common/VirtualAreaLight.h>
#include <lightskin/gl/Readback.h>
#include <lightskin/render/CameraProjection.h>
#include <lightskin/render/MeshLoader.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <vector>

using namespace lightskin;

namespace {

constexpr int kWidth = 160, kHeight = 120;
constexpr double kCreaseDegrees = 13.0;
const double kRidge = std::tan(0.5 * kCreaseDegrees * std::numbers::pi / 180.0); // ridge height per metre

/// The roof over [0, 2]^2 (z up, ridge along x = 1), 8 triangles wound counter-clockwise seen from +z,
/// then the reversed copy of the ridge triangle (0, 1, 4).
std::string roofWithReversedCopyPly() {
    std::ostringstream ply;
    ply.precision(9);
    ply << "ply\nformat ascii 1.0\nelement vertex 9\nproperty float x\nproperty float y\nproperty float z\n"
           "element face 9\nproperty list uchar int vertex_indices\nend_header\n";
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 3; ++x) ply << x << ' ' << y << ' ' << (x == 1 ? kRidge : 0.0) << '\n';
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 2; ++x) {
            const int a = 3 * y + x;
            ply << "3 " << a << ' ' << a + 1 << ' ' << a + 4 << "\n3 " << a << ' ' << a + 4 << ' ' << a + 3 << '\n';
        }
    ply << "3 4 1 0\n";
    return ply.str();
}

/// Camera 2.5 m above the roof's centre looking straight down (x right = world x, image y down = -world y).
Pose cameraPose() {
    glm::dmat4 m(1.0);
    m[0] = glm::dvec4(1, 0, 0, 0);
    m[1] = glm::dvec4(0, -1, 0, 0);
    m[2] = glm::dvec4(0, 0, -1, 0);
    m[3] = glm::dvec4(1, 1, 2.5, 1);
    return Pose::fromMatrix(m);
}

} // namespace

class MeshNormalsGLTest : public test::GlTest {};

TEST_F(MeshNormalsGLTest, BruteForceOnACreaseWithAReversedDuplicateTriangleMatchesTheFaceNormalsLight) {
    const auto path = test::scratchDir("mesh_normals_gl") / "roof.ply";
    std::ofstream(path) << roofWithReversedCopyPly();
    const render::LoadedModel model = render::loadModel(path);
    ASSERT_EQ(model.parts.size(), 1u);
    const TriangleMesh& roof = model.parts[0].mesh;
    const gi::UploadedMesh gpu = gi::UploadedMesh::create(roof);
    gi::MeshInstance instance;
    instance.mesh = &roof;
    instance.gpu = gpu.view();
    instance.material.diffuseAlbedo = glm::vec3(1.0f);
    instance.material.specularAlbedo = glm::vec3(0.0f);
    const std::vector<gi::MeshInstance> instances{instance};

    const CameraIntrinsics k{.width = kWidth, .height = kHeight, .fx = 100.0, .fy = 100.0, .cx = 79.5, .cy = 59.5};
    const Pose pose = cameraPose();
    const glm::mat4 clip(render::clipFromWorld(k, pose, 0.05, 20.0));
    gi::SimpleGBuffer gbuffer = gi::SimpleGBuffer::create(kWidth, kHeight);
    gbuffer.render(instances, clip);

    // One VAL 0.6 m over the ridge's middle, facing down: every roof point sees it within 67 degrees of
    // its face normal, so cos(theta + delta) > 0 (the lower bound binds) on most of the roof.
    gi::VirtualAreaLight val;
    val.position = glm::vec3(1.0f, 1.0f, 0.6f);
    val.normal = glm::vec3(0.0f, 0.0f, -1.0f);
    val.area = float(std::numbers::pi * 0.05 * 0.05);
    val.flux = glm::vec3(1.0f);
    const gl::Buffer valBuffer = gl::Buffer::create(sizeof val, &val);
    const gi::ValSetView set{valBuffer.id(), 1, 0, 0, 0, 0};
    gi::BruteForceSettings settings;
    settings.glossy = false;
    settings.nearFieldArea = false; // eq. 3 as written below; every receiver is > 10 r from the disc
    auto brute = gi::BruteForceIllumination::create(settings);
    brute->prepare(instances);
    const gl::Texture target = gl::Texture::create2D(GL_RGBA32F, kWidth, kHeight);
    brute->render(set, instances, gbuffer.view(), gi::ViewParameters{clip, glm::vec3(pose.translation())}, target.id());
    cv::Mat radiance, position;
    gl::readTextureRgba32fInto(target, radiance);
    gl::readTextureRgba32fInto(gbuffer.position(), position);

    const double delta = kCreaseDegrees * std::numbers::pi / 180.0;
    const glm::dvec3 l(val.position), nl(val.normal);
    const double r2 = double(val.area) / std::numbers::pi;
    int compared = 0, lowerBoundBinds = 0;
    double worstLow = 1e30, worstHigh = 0.0;
    for (int v = 0; v < kHeight; ++v)
        for (int u = 0; u < kWidth; ++u) {
            const cv::Vec4f p = position.at<cv::Vec4f>(v, u);
            if (p[3] == 0.0f) continue;
            const glm::dvec3 x(p[0], p[1], p[2]);
            if (std::abs(x.x - 1.0) < 1e-3) continue; // on the ridge: either face
            const glm::dvec3 nFace = glm::normalize(glm::dvec3(x.x < 1.0 ? -kRidge : kRidge, 0.0, 1.0));
            const glm::dvec3 offset = l - x;
            const double d2 = glm::dot(offset, offset);
            const glm::dvec3 toLight = offset / std::sqrt(d2);
            const double cosI = glm::dot(nFace, toLight), cosJ = -glm::dot(nl, toLight);
            ASSERT_GT(cosI, 0.0);
            ASSERT_GT(cosJ, 0.0);
            // eq. 3-4: E = M w cos(theta_i) = phi cos(theta_j) cos(theta_i) / (pi (r^2 + d^2)); radiance rho/pi E
            const double eFace = double(val.flux.r) * cosJ * cosI / (std::numbers::pi * (r2 + d2));
            const double bf = double(radiance.at<cv::Vec4f>(v, u)[0]) * std::numbers::pi; // rho_d = 1
            const double theta = std::acos(std::min(1.0, cosI));
            const double low = std::max(0.0, std::cos(theta + delta)) / cosI * (1.0 - 1e-4);
            const double high = std::cos(std::max(theta - delta, 0.0)) / cosI * (1.0 + 1e-4);
            const double ratio = bf / eFace;
            EXPECT_GE(ratio, low) << "pixel (" << u << ", " << v << ") at x " << x.x << ", y " << x.y;
            EXPECT_LE(ratio, high) << "pixel (" << u << ", " << v << ") at x " << x.x << ", y " << x.y;
            ++compared;
            if (low > 0.5) ++lowerBoundBinds;
            worstLow = std::min(worstLow, ratio);
            worstHigh = std::max(worstHigh, ratio);
        }
    // The roof covers ~80 x 80 px; nearly all of it must be compared, most with a lower bound that a
    // black pixel breaks.
    EXPECT_GT(compared, 5000);
    EXPECT_GT(lowerBoundBinds, compared / 2);
    RecordProperty("ratio_min", std::to_string(worstLow));
    RecordProperty("ratio_max", std::to_string(worstHigh));
}
