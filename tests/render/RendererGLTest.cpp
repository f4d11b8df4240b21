#include <lightskin/render/Compositor.h>
#include <lightskin/gi/common/NullIndirectIllumination.h>
#include <lightskin/render/Renderer.h>

#include "GlTestEnvironment.h"
#include "TestPaths.h"

#include <lightskin/gl/Readback.h>

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <fstream>
#include <numbers>

using namespace lightskin;
using render::Renderer;
namespace fs = std::filesystem;

namespace {

// Small images: llvmpipe is slow. 80x60 with a principal point off the centre.
const CameraIntrinsics kCamera{80, 60, 80.0, 78.0, 37.3, 31.6, {}};

// A camera somewhere in the world, looking along a tilted axis.
const Pose kWorld_T_camera(glm::angleAxis(0.3, glm::normalize(glm::dvec3(0.3, 1.0, 0.2))), {0.2, -0.1, 0.4});

/// A cube of edge `size` centred at camera-frame `centre`, axis-aligned with the camera.
render::SceneObject cubeInCameraFrame(const glm::dvec3& centre, double size, glm::vec3 albedo) {
    render::SceneObject o;
    o.mesh = test::dataPath("meshes/box_no_normals.obj");
    const glm::dmat4 camera_T_model = glm::translate(glm::dmat4(1.0), centre) * glm::scale(glm::dmat4(1.0), glm::dvec3(size));
    o.world_T_model = glm::mat4(kWorld_T_camera.matrix() * camera_T_model);
    o.material.diffuseAlbedo = albedo;
    o.material.specularAlbedo = glm::vec3(0.0f);
    return o;
}

render::SceneLight pointLightInCameraFrame(const glm::dvec3& position, float power, bool shadows = true) {
    render::SceneLight l;
    l.type = render::LightType::Point;
    l.position = glm::vec3(kWorld_T_camera.transformPoint(position));
    l.power = glm::vec3(power);
    l.castsShadows = shadows;
    return l;
}

double srgbDecode(double encoded) {
    return encoded <= 0.04045 ? encoded / 12.92 : std::pow((encoded + 0.055) / 1.055, 2.4);
}

class RendererGLTest : public test::GlTest {};

} // namespace

// The silhouette of a camera-aligned cube on the optical axis is its front face: its edges are at
// u = cx +- fx * (s/2) / (z - s/2) (same for v). Pixel centres more than 0.5 px inside are covered,
// more than 0.5 px outside are not; the depth output is the front face's z.
TEST_F(RendererGLTest, CubeSilhouetteAndDepthMatchTheIntrinsics) {
    auto renderer = Renderer::create(kCamera);
    render::Scene scene;
    const double z = 1.0, s = 0.3;
    scene.objects.push_back(cubeInCameraFrame({0.0, 0.0, z}, s, glm::vec3(0.5f)));
    renderer->setScene(scene);
    renderer->renderGBuffer(kWorld_T_camera);
    renderer->shade({});
    cv::Mat colour, depth;
    renderer->readOutputsInto(colour, depth);

    const double zFront = z - s / 2;
    const double uMin = kCamera.cx - kCamera.fx * (s / 2) / zFront, uMax = kCamera.cx + kCamera.fx * (s / 2) / zFront;
    const double vMin = kCamera.cy - kCamera.fy * (s / 2) / zFront, vMax = kCamera.cy + kCamera.fy * (s / 2) / zFront;
    int checked = 0;
    for (int v = 0; v < kCamera.height; ++v)
        for (int u = 0; u < kCamera.width; ++u) {
            const bool covered = colour.at<cv::Vec4b>(v, u)[3] == 255;
            const bool inside = u > uMin + 0.5 && u < uMax - 0.5 && v > vMin + 0.5 && v < vMax - 0.5;
            const bool outside = u < uMin - 0.5 || u > uMax + 0.5 || v < vMin - 0.5 || v > vMax + 0.5;
            if (inside) {
                ASSERT_TRUE(covered) << u << "," << v;
                ASSERT_NEAR(depth.at<float>(v, u), zFront, 1e-4);
                ++checked;
            }
            if (outside) {
                ASSERT_FALSE(covered) << u << "," << v;
                ASSERT_EQ(depth.at<float>(v, u), 0.0f);
            }
        }
    EXPECT_GT(checked, 400);
}

TEST_F(RendererGLTest, GBufferHoldsWorldPositionNormalAndMaterial) {
    auto renderer = Renderer::create(kCamera);
    render::Scene scene;
    auto cube = cubeInCameraFrame({0.0, 0.0, 1.0}, 0.3, glm::vec3(0.25f, 0.5f, 0.75f));
    cube.material.specularAlbedo = glm::vec3(0.1f, 0.2f, 0.3f);
    cube.material.specularExponent = 17.0f;
    scene.objects.push_back(cube);
    renderer->setScene(scene);
    renderer->renderGBuffer(kWorld_T_camera);
    const gi::GBufferView& g = renderer->gbuffer();
    ASSERT_EQ(g.width, kCamera.width);
    // Texture::wrap adopts the name: release it again so the renderer keeps ownership.
    const auto readReleased = [&](std::uint32_t id) {
        gl::Texture t = gl::Texture::wrap(id, g.width, g.height);
        cv::Mat out;
        gl::readTextureRgba32fInto(t, out);
        t.release();
        return out;
    };
    const cv::Mat position = readReleased(g.worldPosition), normal = readReleased(g.worldNormal),
                  albedo = readReleased(g.diffuseAlbedo), specular = readReleased(g.specular);
    const int u = int(std::lround(kCamera.cx)), v = int(std::lround(kCamera.cy));
    const cv::Vec4f p = position.at<cv::Vec4f>(v, u);
    EXPECT_EQ(p[3], 1.0f);
    // Expected: the ray through pixel (u,v) meets the front face z = 0.85 (camera frame).
    const glm::dvec3 hitCamera = kCamera.backProject(u, v, 0.85);
    const glm::dvec3 hitWorld = kWorld_T_camera.transformPoint(hitCamera);
    EXPECT_NEAR(p[0], hitWorld.x, 1e-3);
    EXPECT_NEAR(p[1], hitWorld.y, 1e-3);
    EXPECT_NEAR(p[2], hitWorld.z, 1e-3);
    const glm::dvec3 expectedNormal = kWorld_T_camera.transformDirection({0.0, 0.0, -1.0});
    const cv::Vec4f n = normal.at<cv::Vec4f>(v, u);
    EXPECT_NEAR(n[0], expectedNormal.x, 2e-3);
    EXPECT_NEAR(n[1], expectedNormal.y, 2e-3);
    EXPECT_NEAR(n[2], expectedNormal.z, 2e-3);
    EXPECT_NEAR(albedo.at<cv::Vec4f>(v, u)[0], 0.25f, 1.0f / 255.0f);
    EXPECT_NEAR(albedo.at<cv::Vec4f>(v, u)[2], 0.75f, 1.0f / 255.0f);
    EXPECT_NEAR(specular.at<cv::Vec4f>(v, u)[1], 0.2f, 1e-3f);
    EXPECT_EQ(specular.at<cv::Vec4f>(v, u)[3], 17.0f);
    EXPECT_EQ(position.at<cv::Vec4f>(0, 0)[3], 0.0f); // corner: no coverage
}

// Direct light of a point light: L = rho/pi * (P / 4 pi) * cos(theta) / d^2, tone mapped.
TEST_F(RendererGLTest, DirectLightMatchesThePhongFormulaAndShadowsDarken) {
    auto renderer = Renderer::create(kCamera);
    render::Scene scene;
    // Receiver: a big cube whose front face is the plane z = 1.0, |x|,|y| < 0.3 (camera frame).
    scene.objects.push_back(cubeInCameraFrame({0.0, 0.0, 1.3}, 0.6, glm::vec3(0.6f)));
    // Occluder between a light at x = 0.2 and the receiver: its shadow centre is at x = -0.2.
    scene.objects.push_back(cubeInCameraFrame({0.0, 0.0, 0.5}, 0.05, glm::vec3(0.6f)));
    const float power = 20.0f;
    scene.lights.push_back(pointLightInCameraFrame({0.2, 0.0, 0.0}, power));
    renderer->setScene(scene);
    renderer->renderGBuffer(kWorld_T_camera);
    renderer->shade({.includeIndirect = true, .exposureStops = 1.0f, .view = render::DebugView::Final});
    cv::Mat colour, depth;
    renderer->readOutputsInto(colour, depth);
    cv::imwrite((test::scratchDir("renderer_direct") / "direct.png").string(), colour);

    // A lit pixel: x = +0.15 on the receiver plane.
    const glm::dvec3 lit(0.15, 0.0, 1.0);
    const glm::dvec2 litPixel = kCamera.project(lit);
    const int u = int(std::lround(litPixel.x)), v = int(std::lround(litPixel.y));
    const glm::dvec3 hit = kCamera.backProject(u, v, 1.0); // the pixel centre's point on the plane
    const glm::dvec3 toLight = glm::dvec3(0.2, 0.0, 0.0) - hit;
    const double d2 = glm::dot(toLight, toLight), cosTheta = -glm::normalize(toLight).z; // receiver normal: -z
    const double expected = 2.0 * 0.6 / std::numbers::pi * (double(power) / (4.0 * std::numbers::pi)) * cosTheta / d2;
    ASSERT_LT(expected, 1.0); // not clipped by the tone mapping
    const double measured = srgbDecode(colour.at<cv::Vec4b>(v, u)[0] / 255.0);
    // Tolerance: 8-bit sRGB quantisation (half a code value) at this brightness plus G-buffer
    // normal precision (RGBA16F): below 1 %.
    EXPECT_NEAR(measured, expected, 0.01 * expected + 0.004);

    // The shadow centre (x = -0.2) receives no direct light; just outside the shadow it is lit.
    const glm::dvec2 shadowPixel = kCamera.project({-0.2, 0.0, 1.0});
    const cv::Vec4b shadow = colour.at<cv::Vec4b>(int(std::lround(shadowPixel.y)), int(std::lround(shadowPixel.x)));
    EXPECT_EQ(shadow[3], 255);
    EXPECT_EQ(shadow[0], 0);
    const glm::dvec2 besidePixel = kCamera.project({-0.2, 0.12, 1.0}); // outside the 0.1 m wide shadow
    EXPECT_GT(colour.at<cv::Vec4b>(int(std::lround(besidePixel.y)), int(std::lround(besidePixel.x)))[0], 60);
}

// The compositing test: a virtual cube half behind a real box is half hidden.
TEST_F(RendererGLTest, VirtualCubeHalfBehindARealBoxIsHalfHidden) {
    auto renderer = Renderer::create(kCamera);
    render::Scene scene;
    scene.objects.push_back(cubeInCameraFrame({0.0, 0.0, 1.0}, 0.3, glm::vec3(1.0f, 0.0f, 0.0f)));
    renderer->setScene(scene);
    renderer->renderGBuffer(kWorld_T_camera);
    renderer->shade({.includeIndirect = false, .exposureStops = 0.0f, .view = render::DebugView::Albedo});
    cv::Mat colour, depth;
    renderer->readOutputsInto(colour, depth);

    // Real depth: a box at 0.6 m covers the columns left of the principal point; a wall at 2 m elsewhere.
    const int split = int(std::lround(kCamera.cx));
    cv::Mat realDepth(kCamera.height, kCamera.width, CV_32FC1, cv::Scalar(2.0f));
    realDepth.colRange(0, split).setTo(0.6f);
    const cv::Mat camera(kCamera.height, kCamera.width, CV_8UC3, cv::Scalar(90, 90, 90));
    render::Compositor compositor = render::Compositor::create(kCamera);
    cv::Mat out;
    compositor.compositeInto(camera, colour, depth, realDepth, out);
    cv::imwrite((test::scratchDir("composite_half") / "composite.png").string(), out);

    int covered = 0, shown = 0, shownLeft = 0;
    for (int v = 0; v < kCamera.height; ++v)
        for (int u = 0; u < kCamera.width; ++u) {
            if (colour.at<cv::Vec4b>(v, u)[3] == 0) {
                ASSERT_EQ(out.at<cv::Vec3b>(v, u), cv::Vec3b(90, 90, 90));
                continue;
            }
            ++covered;
            const bool virtualShown = out.at<cv::Vec3b>(v, u) == cv::Vec3b(0, 0, 255); // pure red, BGR
            if (virtualShown) ++shown;
            else EXPECT_EQ(out.at<cv::Vec3b>(v, u), cv::Vec3b(90, 90, 90));
            if (virtualShown && u < split) ++shownLeft;
        }
    ASSERT_GT(covered, 500);
    EXPECT_EQ(shownLeft, 0);
    // The cube is centred on the principal point: half its pixels (to within one column) are shown.
    const double columns = std::sqrt(double(covered));
    EXPECT_NEAR(double(shown) / double(covered), 0.5, 1.0 / columns);
}

TEST_F(RendererGLTest, NullTechniqueWritesZeroAndNoVirtualContentLeavesTheFrame) {
    auto renderer = Renderer::create(kCamera);
    renderer->setScene(render::Scene{});
    renderer->renderGBuffer(kWorld_T_camera);
    gi::NullIndirectIllumination none;
    none.render({}, renderer->instances(), renderer->gbuffer(), renderer->viewParameters(), renderer->indirectTarget());
    renderer->shade({});
    cv::Mat colour, depth;
    renderer->readOutputsInto(colour, depth);
    EXPECT_EQ(cv::countNonZero(colour.reshape(1)), 0);
    cv::Mat camera(kCamera.height, kCamera.width, CV_8UC3);
    cv::randu(camera, 0, 256);
    cv::Mat out;
    render::Compositor compositor = render::Compositor::create(kCamera);
    compositor.compositeInto(camera, colour, depth, cv::Mat(), out);
    EXPECT_EQ(cv::norm(out, camera, cv::NORM_INF), 0.0);
}

// A spot light aimed at the receiver lights the inside of its cone with the point-light formula
// (intensity P / 4 pi) and nothing beyond cone + falloff.
TEST_F(RendererGLTest, SpotLightConeLimitsTheLitArea) {
    auto renderer = Renderer::create(kCamera);
    render::Scene scene;
    scene.objects.push_back(cubeInCameraFrame({0.0, 0.0, 1.3}, 0.6, glm::vec3(0.6f))); // front face z = 1.0
    render::SceneLight spot = pointLightInCameraFrame({0.0, 0.0, 0.0}, 20.0f, false);
    spot.type = render::LightType::Spot;
    spot.direction = glm::vec3(kWorld_T_camera.transformDirection({0.0, 0.0, 1.0}));
    spot.coneAngleDegrees = 5.0f;   // full intensity within 0.087 m of the centre at 1 m
    spot.coneFalloffDegrees = 2.0f; // dark beyond tan(7 deg) = 0.123 m
    scene.lights.push_back(spot);
    renderer->setScene(scene);
    renderer->renderGBuffer(kWorld_T_camera);
    renderer->shade({.includeIndirect = false, .exposureStops = 1.0f, .view = render::DebugView::Final});
    cv::Mat colour, depth;
    renderer->readOutputsInto(colour, depth);
    const auto at = [&](double x, double y) {
        const glm::dvec2 p = kCamera.project({x, y, 1.0});
        return colour.at<cv::Vec4b>(int(std::lround(p.y)), int(std::lround(p.x)));
    };
    const glm::dvec2 centre = kCamera.project({0.05, 0.0, 1.0});
    const glm::dvec3 hit = kCamera.backProject(std::round(centre.x), std::round(centre.y), 1.0);
    const double d2 = glm::dot(hit, hit), cosTheta = 1.0 / std::sqrt(d2);
    const double expected = 2.0 * 0.6 / std::numbers::pi * (20.0 / (4.0 * std::numbers::pi)) * cosTheta / d2;
    EXPECT_NEAR(srgbDecode(at(0.05, 0.0)[0] / 255.0), expected, 0.01 * expected + 0.004);
    EXPECT_EQ(at(0.2, 0.0)[0], 0);
    EXPECT_EQ(at(0.0, -0.2)[0], 0);
    EXPECT_EQ(at(0.2, 0.0)[3], 255); // covered, just not lit
}

// A textured quad (OBJ + MTL map_Kd) facing the camera: the albedo view shows the texture's
// four quadrant colours where the texture coordinates put them (v = 0 is the image's bottom row).
TEST_F(RendererGLTest, DiffuseTextureFromMtlIsSampledInSrgb) {
    const fs::path folder = test::scratchDir("renderer_texture");
    cv::Mat texture(64, 64, CV_8UC3);
    texture(cv::Rect(0, 0, 32, 32)).setTo(cv::Scalar(0, 0, 255));    // top left: red (BGR)
    texture(cv::Rect(32, 0, 32, 32)).setTo(cv::Scalar(0, 255, 0));   // top right: green
    texture(cv::Rect(0, 32, 32, 32)).setTo(cv::Scalar(255, 0, 0));   // bottom left: blue
    texture(cv::Rect(32, 32, 32, 32)).setTo(cv::Scalar(128, 128, 128)); // bottom right: sRGB grey 128
    ASSERT_TRUE(cv::imwrite((folder / "quadrants.png").string(), texture));
    std::ofstream(folder / "quad.mtl") << "newmtl tex\nKd 1 1 1\nKs 0 0 0\nmap_Kd quadrants.png\n";
    // Unit quad in z = 0 facing +z, u along +x, v along +y.
    std::ofstream(folder / "quad.obj") << "mtllib quad.mtl\nv -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\n"
                                          "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl tex\nf 1/1 2/2 3/3 4/4\n";
    render::SceneObject quad;
    quad.mesh = folder / "quad.obj";
    // Camera frame: x right, y down, z forward. Model +y must appear up in the image (camera -y) and
    // model +z face the camera (camera -z): rotate 180 degrees about x, place at z = 1.
    const glm::dmat4 camera_T_model = glm::translate(glm::dmat4(1.0), glm::dvec3(0.0, 0.0, 1.0)) *
                                      glm::rotate(glm::dmat4(1.0), glm::pi<double>(), glm::dvec3(1.0, 0.0, 0.0)) *
                                      glm::scale(glm::dmat4(1.0), glm::dvec3(0.6));
    quad.world_T_model = glm::mat4(kWorld_T_camera.matrix() * camera_T_model);
    render::Scene scene;
    scene.objects.push_back(quad);
    auto renderer = Renderer::create(kCamera);
    renderer->setScene(scene);
    renderer->renderGBuffer(kWorld_T_camera);
    renderer->shade({.includeIndirect = false, .exposureStops = 0.0f, .view = render::DebugView::Albedo});
    cv::Mat colour, depth;
    renderer->readOutputsInto(colour, depth);
    const auto at = [&](double x, double y) { // camera-frame point on the quad plane z = 1
        const glm::dvec2 p = kCamera.project({x, y, 1.0});
        return colour.at<cv::Vec4b>(int(std::lround(p.y)), int(std::lround(p.x)));
    };
    EXPECT_EQ(at(-0.15, -0.15), cv::Vec4b(255, 0, 0, 255)); // image top left: red (RGBA)
    EXPECT_EQ(at(0.15, -0.15), cv::Vec4b(0, 255, 0, 255));
    EXPECT_EQ(at(-0.15, 0.15), cv::Vec4b(0, 0, 255, 255));
    // Grey 128 decoded to linear by the sRGB texture and encoded again by the tone mapping: 128 +- 1.
    EXPECT_NEAR(at(0.15, 0.15)[0], 128, 1);
}

// shade() runs only in the rectangle the objects' bounding boxes project to (RendererOptions::shadeCoveredRectOnly)
// and clears the rest: the outputs must equal a whole-viewport shade bit for bit, in every output (colour, depth,
// linear), also after the camera moves (nothing stale outside the new rectangle), with an object cut by the image
// border, and with one reaching behind the near plane (then the rectangle is the whole viewport).
TEST_F(RendererGLTest, ShadingOnlyTheCoveredRectangleGivesTheSameOutputs) {
    render::RendererOptions wholeViewport;
    wholeViewport.shadeCoveredRectOnly = false;
    auto limited = Renderer::create(kCamera), reference = Renderer::create(kCamera, wholeViewport);
    render::Scene scene;
    scene.objects.push_back(cubeInCameraFrame({0.05, 0.02, 1.0}, 0.2, glm::vec3(0.6f, 0.5f, 0.4f)));
    scene.objects.push_back(
        cubeInCameraFrame({0.42, -0.1, 1.2}, 0.25, glm::vec3(0.3f, 0.5f, 0.7f))); // cut by the border
    scene.lights.push_back(pointLightInCameraFrame({0.0, -0.5, 0.3}, 20.0f));
    limited->setScene(scene);
    reference->setScene(scene);
    const auto moved = [](double x, double z) {
        return kWorld_T_camera * Pose(glm::dquat(1.0, 0.0, 0.0, 0.0), glm::dvec3(x, 0.0, z));
    };
    struct View {
        Pose world_T_camera;
        bool wholeRect;
    };
    // 0.85 m forward: the first cube's near face (0.9 m ahead before) is 5 cm ahead, its corners behind the near
    // plane (0.05 m) reach it -> the whole viewport.
    const View views[] = {{kWorld_T_camera, false}, {moved(0.1, 0.0), false}, {moved(0.0, 0.85), true}};
    for (std::size_t i = 0; i < std::size(views); ++i) {
        cv::Mat colour[2], depth[2], linear[2];
        Renderer* renderers[2] = {limited.get(), reference.get()};
        for (int r = 0; r < 2; ++r) {
            renderers[r]->renderGBuffer(views[i].world_T_camera);
            renderers[r]->shade({.includeIndirect = false, .linearOutput = true});
            renderers[r]->readOutputsInto(colour[r], depth[r]);
            renderers[r]->readLinearOutputInto(linear[r]);
        }
        const glm::ivec4 rect = limited->shadedWindowRect();
        const int covered = cv::countNonZero(depth[1] > 0.0f);
        ASSERT_GT(covered, 20) << "view " << i << ": the objects must be in view";
        EXPECT_EQ(cv::norm(colour[0], colour[1], cv::NORM_INF), 0.0) << "view " << i;
        EXPECT_EQ(cv::norm(depth[0], depth[1], cv::NORM_INF), 0.0) << "view " << i;
        EXPECT_EQ(cv::norm(linear[0], linear[1], cv::NORM_INF), 0.0) << "view " << i;
        if (views[i].wholeRect) {
            EXPECT_EQ(rect, glm::ivec4(0, 0, kCamera.width, kCamera.height)) << "view " << i;
        } else {
            // The shortcut is taken: the rectangle is a part of the frame, and holds every covered pixel
            // (image row v is GL window row H-1-v).
            EXPECT_LT(rect.z * rect.w, kCamera.width * kCamera.height * 3 / 4) << "view " << i;
            const cv::Rect image(rect.x, kCamera.height - rect.y - rect.w, rect.z, rect.w);
            EXPECT_EQ(cv::countNonZero(depth[1](image) > 0.0f), covered) << "view " << i;
        }
    }
}

namespace {

/// Every texel of a GL texture as floats (RGBA), rows as GL stores them: no rectangle, no flip.
cv::Mat wholeTexture(GLuint texture, int width, int height, GLenum format = GL_RGBA) {
    cv::Mat out(height, width, format == GL_RGBA ? CV_32FC4 : CV_32FC1);
    glGetTextureImage(texture, 0, format, GL_FLOAT, GLsizei(out.total() * out.elemSize()), out.data);
    return out;
}

} // namespace

// renderGBuffer() and shade() clear only what the previous frame could write (its covered rectangle). The
// whole G-buffer and output textures (what GI techniques and Session::render read, not only the shaded
// rectangle) must still equal a renderer that clears and draws the whole viewport, after the rectangle
// moves, grows to the whole viewport and shrinks again: a pixel written by an earlier frame and not cleared
// would differ. Exact equality: both renderers run the same shaders on the same inputs.
TEST_F(RendererGLTest, ClearingOnlyTheLastRectangleLeavesNoStalePixels) {
    render::RendererOptions wholeViewport;
    wholeViewport.shadeCoveredRectOnly = false;
    auto limited = Renderer::create(kCamera), reference = Renderer::create(kCamera, wholeViewport);
    render::Scene scene;
    scene.objects.push_back(cubeInCameraFrame({0.05, 0.02, 1.0}, 0.2, glm::vec3(0.6f, 0.5f, 0.4f)));
    scene.lights.push_back(pointLightInCameraFrame({0.0, -0.5, 0.3}, 20.0f));
    limited->setScene(scene);
    reference->setScene(scene);
    const auto moved = [](double x, double z) {
        return kWorld_T_camera * Pose(glm::dquat(1.0, 0.0, 0.0, 0.0), glm::dvec3(x, 0.0, z));
    };
    // left, right (disjoint rectangles: the left one's pixels must be cleared), the whole viewport (the
    // cube's corners behind the near plane), the left again (everything else must be cleared)
    const Pose views[] = {moved(0.25, 0.0), moved(-0.25, 0.0), moved(0.0, 0.85), moved(0.25, 0.0)};
    for (std::size_t i = 0; i < std::size(views); ++i) {
        Renderer* renderers[2] = {limited.get(), reference.get()};
        cv::Mat textures[2][7];
        for (int r = 0; r < 2; ++r) {
            renderers[r]->renderGBuffer(views[i]);
            renderers[r]->shade({.includeIndirect = false, .linearOutput = i % 2 == 0});
            const gi::GBufferView& g = renderers[r]->gbuffer();
            textures[r][0] = wholeTexture(g.worldPosition, kCamera.width, kCamera.height);
            textures[r][1] = wholeTexture(g.worldNormal, kCamera.width, kCamera.height);
            textures[r][2] = wholeTexture(g.diffuseAlbedo, kCamera.width, kCamera.height);
            textures[r][3] = wholeTexture(g.specular, kCamera.width, kCamera.height);
            textures[r][4] = wholeTexture(g.depth, kCamera.width, kCamera.height, GL_DEPTH_COMPONENT);
            textures[r][5] = wholeTexture(renderers[r]->outputColourTexture(), kCamera.width, kCamera.height);
            textures[r][6] = wholeTexture(renderers[r]->outputDepthTexture(), kCamera.width, kCamera.height, GL_RED);
        }
        const glm::ivec4 rect = limited->shadedWindowRect();
        if (i != 2) {
            ASSERT_LT(rect.z * rect.w, kCamera.width * kCamera.height / 2) << "view " << i << ": a part";
        }
        ASSERT_GT(cv::countNonZero(textures[1][6] > 0.0f), 20) << "view " << i << ": the cube must be in view";
        for (int t = 0; t < 7; ++t)
            EXPECT_EQ(cv::norm(textures[0][t], textures[1][t], cv::NORM_INF), 0.0) << "view " << i << ", texture " << t;
    }
}

// The G-buffer's facing flag (normal w, gi::GBufferView::worldNormal) through the renderer: a cube without the face
// toward the camera shows only its inside (back faces: w = 1, the normal turned toward the camera); the closed cube
// under a mirroring placement (scale x by -1, its winding clockwise on screen) shows front faces (w = 0). And the
// open cube, placed twice, is warned about once, with its counts (MeshLoadReport::boundaryLoops / boundaryEdges).
TEST_F(RendererGLTest, BackFacesAreFlaggedMirroredPlacementsAreNotAndOpenMeshesAreWarnedAboutOnce) {
    const fs::path folder = fs::temp_directory_path() / "lightskin_renderer_open_cube";
    fs::create_directories(folder);
    const fs::path open = folder / "open_front.obj";
    // The unit cube of box_no_normals.obj's corners without its z = 0 face (2 triangles): 1 hole, 4 boundary edges.
    std::ofstream(open) << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                        << "f 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
    const auto readNormals = [](const Renderer& r) {
        const gi::GBufferView& g = r.gbuffer();
        gl::Texture t = gl::Texture::wrap(g.worldNormal, g.width, g.height);
        cv::Mat out;
        gl::readTextureRgba32fInto(t, out);
        t.release();
        return out;
    };
    const glm::dvec3 towardCamera = kWorld_T_camera.transformDirection({0.0, 0.0, -1.0});
    for (const bool mirrored : {false, true}) {
        SCOPED_TRACE(mirrored ? "closed cube, mirrored" : "open cube");
        auto renderer = Renderer::create(kCamera);
        render::Scene scene;
        // Model [0, 1]^3 centred on the optical axis at z = 1 m, 0.3 m wide: its z = 0 face toward the camera.
        render::SceneObject o = cubeInCameraFrame({0.0, 0.0, 1.0}, 0.3, glm::vec3(0.5f));
        o.mesh = mirrored ? test::dataPath("meshes/box_no_normals.obj") : open;
        if (mirrored) o.world_T_model = o.world_T_model * glm::scale(glm::mat4(1.0f), glm::vec3(-1.0f, 1.0f, 1.0f));
        if (!mirrored) o.world_T_model = o.world_T_model * glm::translate(glm::mat4(1.0f), glm::vec3(-0.5f));
        scene.objects = {o, o};
        testing::internal::CaptureStderr();
        renderer->setScene(scene);
        const std::string log = testing::internal::GetCapturedStderr();
        std::size_t warnings = 0;
        for (std::size_t at = log.find("the mesh is open"); at != std::string::npos;
             at = log.find("the mesh is open", at + 1))
            ++warnings;
        EXPECT_EQ(warnings, mirrored ? 0u : 1u) << log;
        if (!mirrored) {
            EXPECT_NE(log.find("1 hole(s), 4 boundary edges"), std::string::npos) << log;
        }
        renderer->renderGBuffer(kWorld_T_camera);
        const cv::Mat normal = readNormals(*renderer);
        int covered = 0, back = 0;
        for (int v = 0; v < normal.rows; ++v)
            for (int u = 0; u < normal.cols; ++u) {
                const cv::Vec4f n = normal.at<cv::Vec4f>(v, u);
                if (n[0] == 0.0f && n[1] == 0.0f && n[2] == 0.0f) continue; // background (cleared to 0)
                ++covered;
                if (n[3] == 1.0f) ++back;
                EXPECT_TRUE(n[3] == 0.0f || n[3] == 1.0f) << u << ", " << v;
            }
        // The 0.3 m cube at 0.85-1.15 m, f = 80 px: ~20 x 20 px (the open one shows its inside, 21-28 px).
        EXPECT_GT(covered, 300);
        EXPECT_EQ(back, mirrored ? 0 : covered);
        // The centre pixel: the back wall's inside (open) or the front face (mirrored), both facing the camera.
        const cv::Vec4f centre = normal.at<cv::Vec4f>(int(std::lround(kCamera.cy)), int(std::lround(kCamera.cx)));
        EXPECT_NEAR(centre[0], towardCamera.x, 2e-3);
        EXPECT_NEAR(centre[1], towardCamera.y, 2e-3);
        EXPECT_NEAR(centre[2], towardCamera.z, 2e-3);
    }
    fs::remove_all(folder);
}
