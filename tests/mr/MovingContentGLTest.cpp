// Moving content through mr::Session on the bundled synthetic recording (synth-orbit, ground-truth poses):
// an object the host moves is rendered exactly as the scene placing it there; animation keys place objects and
// set lights at the frame's time; hidden, removed and re-added objects leave no trace; bad input changes nothing;
// the adaptive mode never reuses light computed before a move; the GI ahead places animated objects for its frame;
// a glTF clip places its object at the frame's time, as the same placement given as a matrix does.
//
// The scenes run LightSkin on the CPU backend: its VALs come in raster order and its gather does not depend on
// the thread count, so two runs of one frame are bit-identical and images can be compared exactly.
#include "GlTestEnvironment.h"
#include "TestPaths.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/Error.h>
#include <lightskin/mr/Session.h>
#include <lightskin/render/MeshLoader.h>
#include <lightskin/render/Renderer.h>
#include <lightskin/render/Scene.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <limits>
#include <string>

using namespace lightskin;

namespace {

std::filesystem::path recording() { return test::sourceDir() / "recordings" / "synth-orbit"; }
std::filesystem::path sceneFolder() { return test::sourceDir() / "recordings" / "scenes"; }

// The orbit scene's cube, as the file places it.
constexpr const char* kCubeTransform =
    R"("transform": {"translation": [2.38, 1.55, 0.81], "rotationDegrees": [0, 0, 30], "scale": 0.12})";

/// The orbit scene (bunny, glossy cube, a 60 W light) with few sparse points, on the CPU backend, with
/// `replace` applied to its text (each pair: text, replacement).
mr::SceneInput orbitScene(std::initializer_list<std::pair<std::string, std::string>> replace = {},
                          const std::string& backend = "cpu") {
    std::string text = test::readText(sceneFolder() / "orbit.json");
    const auto edit = [&](const std::string& from, const std::string& to) {
        const auto at = text.find(from);
        EXPECT_NE(at, std::string::npos) << from;
        if (at != std::string::npos) text.replace(at, from.size(), to);
    };
    edit("\"sparsePoints\": 1024", "\"sparsePoints\": 256");
    edit("\"technique\": \"lightskin\",", "\"technique\": \"lightskin\", \"backend\": \"" + backend + "\",");
    for (const auto& [from, to] : replace) edit(from, to);
    return mr::SceneInput::fromJson(text, sceneFolder());
}

/// Frame `index` of the recording as a host frame (its ground-truth pose), with a chosen timestamp.
struct HostFrameData {
    RgbdFrame frame;
    cv::Mat rgb;
    mr::HostFrame host;
};
HostFrameData hostFrame(int index, double timestampSeconds) {
    auto source = capture::openFrameSource(recording(), {});
    HostFrameData d;
    for (int i = 0; i <= index; ++i) EXPECT_TRUE(source->next(d.frame));
    cv::cvtColor(d.frame.colour, d.rgb, cv::COLOR_BGR2RGB);
    d.host.rgb = d.rgb.data;
    d.host.depth = d.frame.depth.ptr<std::uint16_t>();
    d.host.depthScaleMetres = d.frame.depthScaleMetres;
    d.host.intrinsics = d.frame.colourIntrinsics;
    d.host.timestampSeconds = timestampSeconds;
    d.host.world_T_camera = d.frame.groundTruth_world_T_camera;
    return d;
}

std::unique_ptr<mr::Session> hostSession(const mr::SceneInput& scene, const RgbdFrame& frame,
                                         const mr::SessionOptions& options = {}) {
    return mr::Session::create(options, scene, frame.colourIntrinsics);
}

void expectSameImage(const mr::FrameOutput& a, const mr::FrameOutput& b, const std::string& what) {
    ASSERT_EQ(a.withGi.size(), b.withGi.size()) << what;
    EXPECT_EQ(cv::norm(a.withGi, b.withGi, cv::NORM_INF), 0.0) << what << ": not bit for bit";
    EXPECT_EQ(a.coveredPixels, b.coveredPixels) << what;
}

/// Pixels whose colour differs by more than one code value: what a move must change.
int changedPixels(const cv::Mat& a, const cv::Mat& b) {
    cv::Mat difference, grey;
    cv::absdiff(a, b, difference);
    cv::cvtColor(difference, grey, cv::COLOR_BGR2GRAY);
    return cv::countNonZero(grey > 1);
}

class MovingContentGLTest : public test::GlTest {};

TEST_F(MovingContentGLTest, AnObjectTheHostMovesIsRenderedAsTheScenePlacingItThere) {
    HostFrameData f = hostFrame(0, 0.0);
    const glm::vec3 translation(2.20f, 1.75f, 0.81f), rotation(0.0f, 0.0f, 75.0f);
    auto moved = hostSession(orbitScene(), f.frame);
    moved->submit(f.host);
    const cv::Mat before = moved->output().withGi.clone();
    ASSERT_GT(moved->report().coveredPixels, 1000);
    moved->setObjectTransform(1, render::composeTransform(translation, rotation, 0.12f));
    moved->submit(f.host);

    auto placed = hostSession(orbitScene({{kCubeTransform, R"("transform": {"translation": [2.20, 1.75, 0.81], )"
                                                           R"("rotationDegrees": [0, 0, 75], "scale": 0.12})"}}),
                              f.frame);
    placed->submit(f.host);
    expectSameImage(moved->output(), placed->output(), "moved by the host vs placed by the scene");
    EXPECT_TRUE(placed->output().giActive);
    // The move is visible: the cube left ~its area of pixels and covers new ones (the differential's shadow too).
    EXPECT_GT(changedPixels(before, moved->output().withGi), 500);
    EXPECT_EQ(moved->scene().objects[1].world_T_model, render::composeTransform(translation, rotation, 0.12f));
}

TEST_F(MovingContentGLTest, AnimationKeysPlaceObjectsAndSetLightsAtTheFramesTime) {
    // The cube slides 0.4 m along -x and turns 90 degrees in 2 s; the light dims from 60 W to 20 W in 4 s.
    auto session = hostSession(
        orbitScene({{kCubeTransform,
                     R"("animation": {"keys": [)"
                     R"({"t": 0, "translation": [2.38, 1.55, 0.81], "rotationDegrees": [0, 0, 30], "scale": 0.12},)"
                     R"({"t": 2, "translation": [1.98, 1.55, 0.81], "rotationDegrees": [0, 0, 120], "scale": 0.12}]})"},
                    {R"("power": 60, "shadows": true})",
                     R"("power": 60, "shadows": true, "animation": {"keys": [{"t": 0}, {"t": 4, "power": 20}]}})"}}),
        hostFrame(0, 0.0).frame);
    HostFrameData f = hostFrame(0, 100.0); // the animation's clock starts at the first frame's timestamp
    session->submit(f.host);
    const cv::Mat atStart = session->output().withGi.clone();
    const auto placementAt = [](float x, float degrees) {
        return render::composeTransform({x, 1.55f, 0.81f}, {0.0f, 0.0f, degrees}, 0.12f);
    };
    const auto expectPlacement = [&](const glm::mat4& expected, const char* when) {
        const glm::mat4& m = session->scene().objects[1].world_T_model;
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r) EXPECT_NEAR(m[c][r], expected[c][r], 1e-5f) << when << ", element " << c << r;
    };
    expectPlacement(placementAt(2.38f, 30.0f), "t = 0");
    EXPECT_EQ(session->scene().lights[0].power, glm::vec3(60.0f));

    f.host.timestampSeconds = 101.0; // half way: 0.2 m and 45 degrees; the light at 50 W
    session->submit(f.host);
    expectPlacement(placementAt(2.18f, 75.0f), "t = 1 s");
    EXPECT_NEAR(session->scene().lights[0].power.r, 50.0f, 1e-4f);
    EXPECT_GT(changedPixels(atStart, session->output().withGi), 500) << "the frame at 1 s shows the motion";

    f.host.timestampSeconds = 107.0; // past the last key: held (no loop)
    session->submit(f.host);
    expectPlacement(placementAt(1.98f, 120.0f), "t = 7 s");
    EXPECT_NEAR(session->scene().lights[0].power.r, 20.0f, 1e-4f);

    // The host takes over: its transform stops the animation.
    session->setObjectTransform(1, placementAt(2.38f, 30.0f));
    f.host.timestampSeconds = 108.0;
    session->submit(f.host);
    expectPlacement(placementAt(2.38f, 30.0f), "after the host's transform");
    EXPECT_FALSE(session->scene().objects[1].animation.has_value());
}

TEST_F(MovingContentGLTest, BadInputIsAnErrorNamingTheObjectAndChangesNothing) {
    HostFrameData f = hostFrame(0, 0.0);
    auto session = hostSession(orbitScene(), f.frame);
    session->submit(f.host);
    const cv::Mat before = session->output().withGi.clone();
    const float nan = std::numeric_limits<float>::quiet_NaN();
    glm::mat4 sheared(1.0f);
    sheared[1][0] = 0.3f;
    glm::mat4 stretched = glm::mat4(1.0f);
    stretched[2][2] = 2.0f;
    glm::mat4 lastRow(1.0f);
    lastRow[0][3] = 1.0f;
    const auto expectError = [&](auto&& call, const std::string& names, const std::string& cause) {
        try {
            call();
            ADD_FAILURE() << "no error; expected '" << cause << "'";
        } catch (const Error& error) {
            const std::string what = error.what();
            EXPECT_NE(what.find(names), std::string::npos) << what;
            EXPECT_NE(what.find(cause), std::string::npos) << what;
        }
    };
    expectError([&] { session->setObjectTransform(2, glm::mat4(1.0f)); }, "object 2",
                "no such object (the scene has 2)");
    expectError([&] { session->setObjectTransform(0, glm::mat4(nan)); }, "object 0", "non-finite");
    expectError(
        [&] {
            session->setObjectTransform(
                0, glm::mat4(0.0f) + glm::mat4(glm::vec4(0), glm::vec4(0), glm::vec4(0), glm::vec4(0, 0, 0, 1)));
        },
        "object 0", "singular");
    expectError([&] { session->setObjectTransform(1, sheared); }, "object 1", "no shear");
    expectError([&] { session->setObjectTransform(1, stretched); }, "object 1", "no shear, no stretch");
    expectError([&] { session->setObjectTransform(1, lastRow); }, "object 1", "last row");
    expectError([&] { session->setObjectVisible(5, false); }, "object 5", "no such object");
    render::MaterialOverride tooBright;
    tooBright.diffuseAlbedo = glm::vec3(1.5f, 0.5f, 0.5f);
    expectError([&] { session->setObjectMaterial(0, tooBright); }, "object 0", "diffuse albedo must be in [0, 1]");
    expectError([&] { session->setLight(0, {2, 1.6f, 2.3f}, {0, 0, -1}, {-1, 60, 60}); }, "light 0", "power");
    expectError([&] { session->setLight(0, {nan, 1.6f, 2.3f}, {0, 0, -1}, glm::vec3(60)); }, "light 0", "position");
    expectError([&] { session->setLight(1, {2, 1.6f, 2.3f}, {0, 0, -1}, glm::vec3(60)); }, "light 1", "no such light");
    render::SceneObject missing;
    missing.name = "ghost";
    missing.mesh = sceneFolder() / "meshes" / "no-such-mesh.obj";
    expectError([&] { session->addObject(missing); }, "no-such-mesh.obj", "does not exist");
    render::SceneObject broken = missing; // exists, but is no mesh
    broken.mesh = sceneFolder() / "orbit.json";
    expectError([&] { session->addObject(broken); }, "orbit.json", "ghost");
    expectError([&] { session->removeObject(2); }, "object 2", "no such object");

    ASSERT_EQ(session->scene().objects.size(), 2u);
    session->submit(f.host);
    EXPECT_EQ(cv::norm(session->output().withGi, before, cv::NORM_INF), 0.0) << "an error changed the content";
}

TEST_F(MovingContentGLTest, HiddenRemovedAndReAddedObjectsLeaveNoTrace) {
    HostFrameData f = hostFrame(0, 0.0);
    auto session = hostSession(orbitScene(), f.frame);
    session->submit(f.host);
    const mr::FrameOutput original = session->output();
    const cv::Mat originalImage = original.withGi.clone();

    // Hidden cube = a scene without the cube.
    auto bunnyOnly = hostSession(orbitScene({{R"(    {
      "name": "cube",)",
                                              R"(    {"visible": false,
      "name": "cube",)"}}),
                                 f.frame);
    session->setObjectVisible(1, false);
    session->submit(f.host);
    bunnyOnly->submit(f.host);
    expectSameImage(session->output(), bunnyOnly->output(), "cube hidden by the host vs by the scene");
    EXPECT_LT(session->report().coveredPixels, original.coveredPixels);

    // Nothing visible: the camera image passes unchanged (no GI, no differential shadow left behind).
    session->setObjectVisible(0, false);
    session->submit(f.host);
    EXPECT_EQ(session->report().coveredPixels, 0);
    EXPECT_EQ(cv::norm(session->output().withGi, f.frame.colour, cv::NORM_INF), 0.0);

    session->setObjectVisible(0, true);
    session->setObjectVisible(1, true);
    session->submit(f.host);
    EXPECT_EQ(cv::norm(session->output().withGi, originalImage, cv::NORM_INF), 0.0) << "shown again";

    // Removed and added again as it was: the original image.
    const render::SceneObject cube = session->scene().objects[1];
    session->removeObject(1);
    ASSERT_EQ(session->scene().objects.size(), 1u);
    session->submit(f.host);
    expectSameImage(session->output(), bunnyOnly->output(), "cube removed vs hidden by the scene");
    EXPECT_EQ(session->addObject(cube), 1u);
    session->submit(f.host);
    EXPECT_EQ(cv::norm(session->output().withGi, originalImage, cv::NORM_INF), 0.0) << "re-added";
}

TEST_F(MovingContentGLTest, MaterialAndLightChangesShowAndUndoExactly) {
    HostFrameData f = hostFrame(0, 0.0);
    auto session = hostSession(orbitScene(), f.frame);
    session->submit(f.host);
    const cv::Mat original = session->output().withGi.clone();
    render::MaterialOverride red;
    red.diffuseAlbedo = glm::vec3(0.8f, 0.1f, 0.1f);
    session->setObjectMaterial(0, red);
    session->submit(f.host);
    EXPECT_GT(changedPixels(original, session->output().withGi), 300) << "the bunny turned red";
    render::MaterialOverride asInScene;
    asInScene.diffuseAlbedo = glm::vec3(0.7f, 0.68f, 0.64f);
    session->setObjectMaterial(0, asInScene);
    session->setLight(0, {2.0f, 1.6f, 1.2f}, {0, 0, -1}, glm::vec3(60.0f)); // lowered to just above the table
    session->submit(f.host);
    EXPECT_GT(changedPixels(original, session->output().withGi), 300) << "the light moved: direct light and shadows";
    auto lowered =
        hostSession(orbitScene({{R"("position": [2.0, 1.6, 2.3])", R"("position": [2.0, 1.6, 1.2])"}}), f.frame);
    lowered->submit(f.host);
    expectSameImage(session->output(), lowered->output(), "light moved by the host vs placed by the scene");
    session->setLight(0, {2.0f, 1.6f, 2.3f}, {0, 0, -1}, glm::vec3(60.0f));
    session->submit(f.host);
    EXPECT_EQ(cv::norm(session->output().withGi, original, cv::NORM_INF), 0.0) << "back as in the scene";
}

// LightSkin's adaptive mode reuses the last light while nothing changed; a move must end the reuse at once.
TEST_F(MovingContentGLTest, AdaptiveReuseEndsWhenAnObjectMoves) {
    HostFrameData f = hostFrame(0, 0.0);
    mr::SessionOptions options;
    options.pipeline.adaptive = true;
    auto session = hostSession(orbitScene({}, "gl"), f.frame, options);
    session->submit(f.host);
    session->submit(f.host);
    ASSERT_EQ(session->output().giReused, 1) << "the same frame again: reused";
    session->setObjectTransform(1, render::composeTransform({2.30f, 1.60f, 0.81f}, {0, 0, 30}, 0.12f));
    session->submit(f.host);
    EXPECT_EQ(session->output().giReused, 0) << "moved: computed";
    session->submit(f.host);
    EXPECT_EQ(session->output().giReused, 1) << "still again: reused";
}

// With the prefetch, the CPU backend computes frame n+1's GI during frame n, with the animated objects placed for
// frame n+1's time: the images equal the sequential session's bit for bit, and the work ahead is used. A host's
// move between two frames is not known ahead: that frame computes its own GI, the next one uses the ahead again.
TEST_F(MovingContentGLTest, GiAheadPlacesAnimatedObjectsForTheNextFrame) {
    const mr::SceneInput scene = orbitScene(
        {{kCubeTransform,
          R"("animation": {"loop": true, "keys": [)"
          R"({"t": 0, "translation": [2.38, 1.55, 0.81], "rotationDegrees": [0, 0, 30], "scale": 0.12},)"
          R"({"t": 0.2, "translation": [2.18, 1.65, 0.81], "rotationDegrees": [0, 0, 90], "scale": 0.12}]})"}});
    mr::SessionOptions sequentialOptions, prefetchOptions;
    prefetchOptions.prefetch = true;
    auto sequential = mr::Session::create(sequentialOptions, scene, capture::openFrameSource(recording(), {}));
    auto prefetching = mr::Session::create(prefetchOptions, scene, capture::openFrameSource(recording(), {}));
    constexpr int kFrames = 6, kHostMoveAt = 3;
    for (int frame = 0; frame < kFrames; ++frame) {
        if (frame == kHostMoveAt)
            for (mr::Session* session : {sequential.get(), prefetching.get()})
                session->setObjectTransform(0, render::composeTransform({1.60f, 1.90f, 0.70f}, {90, 0, 10}, 1.5f));
        ASSERT_TRUE(sequential->processNext());
        ASSERT_TRUE(prefetching->processNext());
        expectSameImage(sequential->output(), prefetching->output(), "frame " + std::to_string(frame));
        EXPECT_TRUE(prefetching->output().giActive);
        EXPECT_EQ(prefetching->output().giComputedAhead, frame > 0 && frame != kHostMoveAt) << "frame " << frame;
    }
}

TEST_F(MovingContentGLTest, AGltfClipPlacesItsObjectAtTheFramesTime) {
    // The cube's place taken by swinging_box.gltf playing its clip "Swing" (its closed form:
    // tests/render/GltfAnimationTest.cpp) inside a transform that stands the file's y-up on the table.
    const std::string mesh = test::dataPath("meshes/swinging_box.gltf").string();
    const std::string transform =
        R"("transform": {"translation": [1.98, 1.6, 0.70], "rotationDegrees": [90, 0, 0], "scale": 0.3})";
    auto animated =
        hostSession(orbitScene({{R"("meshes/cube.obj")", "\"" + mesh + "\""},
                                {kCubeTransform, R"("animation": {"source": "gltf", "clip": "Swing"}, )" + transform}}),
                    hostFrame(0, 0.0).frame);
    HostFrameData f = hostFrame(0, 50.0);
    animated->submit(f.host);
    const cv::Mat atStart = animated->output().withGi.clone();
    const glm::mat4 start = animated->scene().objects[1].world_T_model;
    f.host.timestampSeconds = 50.5; // clip time 0.5 s: lifted 0.5 and turned 22.5 degrees (file units)
    animated->submit(f.host);
    const glm::mat4 placed = animated->scene().objects[1].world_T_model;
    EXPECT_EQ(placed, render::placementAt(animated->scene().objects[1], 0.5)) << "the frame's clip time";
    EXPECT_NE(placed, start);
    EXPECT_GT(changedPixels(atStart, animated->output().withGi), 50) << "the frame at 0.5 s shows the motion";

    // The same placement given as a fixed matrix renders the same image, bit for bit.
    std::string matrix;
    for (int row = 0; row < 4; ++row)
        for (int col = 0; col < 4; ++col) {
            char number[32];
            std::snprintf(number, sizeof number, "%.9g", double(placed[col][row]));
            matrix += (matrix.empty() ? "" : ", ") + std::string(number);
        }
    auto fixed = hostSession(orbitScene({{R"("meshes/cube.obj")", "\"" + mesh + "\""},
                                         {kCubeTransform, R"("transform": {"matrix": [)" + matrix + "]}"}}),
                             f.frame);
    fixed->submit(f.host);
    EXPECT_EQ(fixed->scene().objects[1].world_T_model, placed);
    expectSameImage(animated->output(), fixed->output(), "clip at 0.5 s vs its placement as a matrix");
    const std::int64_t covered = animated->output().coveredPixels;
    fixed->setObjectVisible(1, false);
    fixed->submit(f.host);
    EXPECT_LT(fixed->output().coveredPixels, covered) << "the box is in view at 0.5 s";
}

TEST_F(MovingContentGLTest, ASkinnedClipDeformsItsObjectWhatTheTechniquesSeeFollows) {
    // bending_cylinder.gltf (scripts/make_gltf_samples.py): 2 m tall, radius 0.2 m, its upper half turning about +z
    // through the joint [0, 1, 0] by 90 t degrees; a vertex at height y weighs the upper bone
    // w = clamp((y - 0.75) / 0.5, 0, 1). Scaled to 20 cm and stood up on the table in the cube's place.
    const std::string mesh = test::dataPath("meshes/bending_cylinder.gltf").string();
    const auto scene = [&](const std::string& technique) {
        return orbitScene(
            {{R"("meshes/cube.obj")", "\"" + mesh + "\""},
             {kCubeTransform,
              R"("animation": {"source": "gltf", "clip": "Bend"}, )"
              R"("transform": {"translation": [2.3, 1.55, 0.75], "rotationDegrees": [90, 0, 0], "scale": 0.1})"},
             {"\"technique\": \"lightskin\", \"backend\": \"cpu\"", technique}});
    };
    auto session = hostSession(scene(R"("technique": "lightskin", "backend": "cpu")"), hostFrame(0, 0.0).frame);
    HostFrameData f = hostFrame(0, 50.0);
    session->submit(f.host);
    const cv::Mat atStart = session->output().withGi.clone();
    f.host.timestampSeconds = 50.5; // bent by 45 degrees
    session->submit(f.host);
    EXPECT_TRUE(session->output().giActive);
    EXPECT_GT(changedPixels(atStart, session->output().withGi), 20) << "the frame at 0.5 s shows the bend";

    // What the renderer and the techniques read: the deformed vertices (model space) and sparse points.
    const render::LoadedModel rest = render::loadModel(mesh);
    const render::Renderer& renderer = session->pipeline().renderer();
    const gi::MeshInstance* cylinder = nullptr;
    for (const gi::MeshInstance& instance : renderer.instances())
        if (renderer.sceneObjectOf(instance.meshId) == 1) cylinder = &instance;
    ASSERT_NE(cylinder, nullptr);
    ASSERT_EQ(cylinder->mesh->vertexCount(), rest.parts.at(0).mesh.vertexCount()) << "a skinned mesh is not refined";
    const double angle = glm::radians(45.0);
    for (std::size_t v = 0; v < rest.parts[0].mesh.vertexCount(); ++v) {
        const glm::dvec3 p(rest.parts[0].mesh.positions[v]), joint(0.0, 1.0, 0.0);
        const double w = std::clamp((p.y - 0.75) / 0.5, 0.0, 1.0);
        const glm::dvec3 q = p - joint;
        const glm::dvec3 turned = joint + glm::dvec3(std::cos(angle) * q.x - std::sin(angle) * q.y,
                                                     std::sin(angle) * q.x + std::cos(angle) * q.y, q.z);
        // Float skinning of coordinates < 2.2 m: < 3e-6 m (tests/render/SkinningTest.cpp); 1e-5 m.
        EXPECT_LE(glm::length(glm::dvec3(cylinder->mesh->positions[v]) - ((1.0 - w) * p + w * turned)), 1e-5) << v;
    }
    const gi::SparsePointSet* points = renderer.sparsePoints(cylinder->meshId);
    ASSERT_NE(points, nullptr);
    ASSERT_EQ(points->anchors.size(), points->points.size());
    const TriangleMesh& bent = *cylinder->mesh;
    for (const gi::SurfaceAnchor& anchor : points->anchors) {
        const std::size_t i = std::size_t(&anchor - points->anchors.data());
        const std::uint32_t* c = &bent.indices[3 * std::size_t(anchor.triangle)];
        const glm::vec3 expected = (1.0f - anchor.u - anchor.v) * bent.positions[c[0]] +
                                   anchor.u * bent.positions[c[1]] + anchor.v * bent.positions[c[2]];
        EXPECT_LE(glm::length(points->points[i].position - expected), 1e-6f) << "sparse point " << i;
    }

    // Multi-scale PRT cannot follow a deformation: refused by name instead of lighting a stale shape.
    try {
        hostSession(scene(R"("technique": "multiscale-prt")"), hostFrame(0, 0.0).frame);
        FAIL() << "multi-scale PRT with a skinned object";
    } catch (const Error& error) {
        EXPECT_NE(error.cause().find("/objects/1 ('cube'): a skinned mesh deforms"), std::string::npos)
            << error.cause();
    }
}

} // namespace
