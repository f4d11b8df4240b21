#include "TestPaths.h"

#include <lightskin/core/Error.h>
#include <lightskin/render/GltfAnimation.h>
#include <lightskin/render/MeshLoader.h>
#include <lightskin/render/Scene.h>

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <cmath>

using lightskin::Error;
using namespace lightskin::render;

namespace {

std::filesystem::path meshDir() { return lightskin::test::dataPath("meshes"); }
std::filesystem::path swingingBox() { return meshDir() / "swinging_box.gltf"; }

// swinging_box.gltf (scripts/make_gltf_samples.py): the box's local point p sits at
//   Base + Arm(t) * (Tip + p), Base = [1, 0, 0], Tip = [0.2, 0, 0],
//   Arm(t) = translate([0, 0.5 + min(t, 1), 0]) * Rz(45 deg * min(t, 2))   (clip "Swing")
// and loadModel's rest-pose vertex is v = Base + [0, 0.5, 0] + Tip + p.
glm::vec3 swingClosedForm(const glm::vec3& p, double t) {
    const double angle = glm::radians(45.0) * std::min(t, 2.0);
    const glm::dvec3 q = glm::dvec3(0.2, 0.0, 0.0) + glm::dvec3(p);
    const glm::dvec3 rotated(std::cos(angle) * q.x - std::sin(angle) * q.y,
                             std::sin(angle) * q.x + std::cos(angle) * q.y, q.z);
    return glm::vec3(glm::dvec3(1.0, 0.0, 0.0) + glm::dvec3(0.0, 0.5 + std::min(t, 1.0), 0.0) + rotated);
}
glm::vec3 restVertex(const glm::vec3& p) { return glm::vec3(1.2f, 0.5f, 0.0f) + p; }

// Float: every coordinate is <= 3 m and takes a handful of float products and sums (ulp 2.4e-7 m at 2 m):
// 1e-5 m is far above that rounding and far below any error of the motion (the smallest, a key time read a
// tick off, moves the box by 1 mm).
constexpr float kMetres = 1e-5f;

void expectNear(const glm::vec3& a, const glm::vec3& b, const std::string& what) {
    EXPECT_NEAR(a.x, b.x, kMetres) << what;
    EXPECT_NEAR(a.y, b.y, kMetres) << what;
    EXPECT_NEAR(a.z, b.z, kMetres) << what;
}

std::string causeOf(const std::string& objectJson) {
    try {
        parseScene(R"({"version": 1, "objects": [)" + objectJson + "]}", meshDir(), "test.json");
    } catch (const Error& error) {
        EXPECT_EQ(error.source(), "test.json");
        return error.cause();
    }
    return "(no error)";
}

} // namespace

TEST(GltfAnimation, RigidClipMatchesTheClosedFormAtAndBetweenKeys) {
    const RigidClip clip = loadRigidClip(swingingBox(), {});
    EXPECT_EQ(clip.clip.name, "Swing");
    EXPECT_EQ(clip.clip.index, 0u);
    EXPECT_NEAR(clip.clip.durationSeconds, 2.0, 1e-9) << "the rotation channel's last key";
    ASSERT_GE(clip.clip.tree.nodes.size(), 3u) << "(assimp's root,) Base, Arm, Tip";
    EXPECT_EQ(clip.clip.tree.nodes.back().name, "Tip");
    // The loaded rest pose is what sampleRigidClip's motion applies to.
    const LoadedModel model = loadModel(swingingBox());
    const glm::vec3 corner(0.05f, -0.05f, 0.05f);
    bool found = false;
    for (const glm::vec3& v : model.parts.at(0).mesh.positions)
        found = found || glm::length(v - restVertex(corner)) < kMetres;
    EXPECT_TRUE(found) << "loadModel bakes the rest pose of the node chain into the vertices";

    for (const double t : {0.0, 0.25, 0.5, 1.0, 1.5, 2.0, 3.0}) {
        const glm::mat4 m = sampleRigidClip(clip, t);
        for (const glm::vec3 p : {corner, glm::vec3(-0.05f, 0.05f, -0.05f)})
            expectNear(glm::vec3(m * glm::vec4(restVertex(p), 1.0f)), swingClosedForm(p, t),
                       "t = " + std::to_string(t));
    }
}

TEST(GltfAnimation, PoseIntoGivesEveryNodesFileTransform) {
    const RigidClip clip = loadRigidClip(swingingBox(), {});
    std::vector<glm::mat4> pose;
    poseInto(clip.clip.tree, 1.0, pose);
    ASSERT_EQ(pose.size(), clip.clip.tree.nodes.size());
    // Tip's origin at t = 1: Base + [0, 1.5, 0] + Rz(45 deg) [0.2, 0, 0]
    const float c = 0.2f * std::sqrt(0.5f);
    expectNear(glm::vec3(pose.back()[3]), glm::vec3(1.0f + c, 1.5f + c, 0.0f), "Tip at t = 1");
}

TEST(GltfAnimation, SceneComposesTheObjectTransformOutsideTheClip) {
    const Scene scene = parseScene(
        R"({"version": 1, "objects": [{"mesh": "swinging_box.gltf", "animation": "gltf",
             "transform": {"translation": [0, 0, 2], "rotationDegrees": [0, 90, 0], "scale": 0.5}}]})",
        meshDir(), "test.json");
    const SceneObject& o = scene.objects.at(0);
    ASSERT_TRUE(o.gltfAnimation.has_value());
    EXPECT_TRUE(isAnimated(o));
    const glm::mat4 world_T_file = composeTransform({0, 0, 2}, {0, 90, 0}, 0.5f);
    const glm::vec3 p(0.05f, 0.05f, 0.05f);
    for (const double t : {0.0, 0.6, 1.7, 5.0}) {
        const glm::vec3 expected(world_T_file * glm::vec4(swingClosedForm(p, t), 1.0f));
        expectNear(glm::vec3(placementAt(o, t) * glm::vec4(restVertex(p), 1.0f)), expected, "t = " + std::to_string(t));
    }
    EXPECT_EQ(o.world_T_model, placementAt(o, 0.0)) << "an animated object starts at its clip's first pose";
}

TEST(GltfAnimation, ClipByNameOrIndexAndLoop) {
    // "Lift": translation [0, 0.5, 0] -> [0, 0.5, 1] over 0.5 s; looped, t = 0.8 plays 0.3 s: z = 0.6.
    for (const char* clip : {"\"Lift\"", "1"}) {
        const Scene scene = parseScene(std::string(R"({"version": 1, "objects": [{"mesh": "swinging_box.gltf",
             "animation": {"source": "gltf", "clip": )") +
                                           clip + R"(, "loop": true}}]})",
                                       meshDir(), "test.json");
        const SceneObject& o = scene.objects.at(0);
        EXPECT_EQ(o.gltfAnimation->rigid.clip.name, "Lift");
        EXPECT_NEAR(o.gltfAnimation->rigid.clip.durationSeconds, 0.5, 1e-9);
        const glm::vec3 p(0.0f);
        expectNear(glm::vec3(placementAt(o, 0.8) * glm::vec4(restVertex(p), 1.0f)), glm::vec3(1.2f, 0.5f, 0.6f),
                   "looped");
    }
    const Scene once = parseScene(
        R"({"version": 1, "objects": [{"mesh": "swinging_box.gltf", "animation": {"source": "gltf", "clip": "Lift"}}]})",
        meshDir(), "test.json");
    expectNear(glm::vec3(placementAt(once.objects[0], 0.8) * glm::vec4(restVertex({}), 1.0f)),
               glm::vec3(1.2f, 0.5f, 1.0f), "not looped: holds the last key");
}

TEST(GltfAnimation, BadInputsNameTheKeyAndTheFile) {
    const auto expectCause = [](const std::string& object, const std::vector<std::string>& parts) {
        const std::string cause = causeOf(object);
        for (const std::string& part : parts) EXPECT_NE(cause.find(part), std::string::npos) << cause;
    };
    expectCause(R"({"mesh": "swinging_box.gltf", "animation": {"source": "gltf", "clip": "Nope"}})",
                {"/objects/0/animation:", "swinging_box.gltf", "no clip named 'Nope'", "0 'Swing', 1 'Lift'"});
    expectCause(R"({"mesh": "swinging_box.gltf", "animation": {"source": "gltf", "clip": 2}})",
                {"/objects/0/animation:", "no clip 2"});
    expectCause(R"({"mesh": "swinging_box.gltf", "animation": {"source": "gltf", "clip": -1}})",
                {"/objects/0/animation/clip:", "a clip's name or its index"});
    expectCause(R"({"mesh": "swinging_box.gltf", "animation": {"source": "fbx"}})", {"/objects/0/animation/source:"});
    expectCause(R"({"mesh": "swinging_box.gltf", "animation": {"source": "gltf", "speed": 2}})",
                {"/objects/0/animation", "speed"});
    expectCause(R"({"mesh": "triangle.gltf", "animation": "gltf"})",
                {"/objects/0/animation:", "triangle.gltf", "has no animation"});
    expectCause(R"({"mesh": "swinging_box_nan_key.gltf", "animation": "gltf"})",
                {"/objects/0/animation:", "swinging_box_nan_key.gltf", "clip 0 'Swing', channel 0 (node 'Arm')",
                 "position key 1", "non-finite translation"});
    expectCause(
        R"({"mesh": "swinging_box_stretched_base.gltf", "animation": "gltf"})",
        {"/objects/0/animation:", "node 'Base' above the animated node 'Arm' has a shear or a non-uniform scale"});
    expectCause(R"({"mesh": "bending_cylinder.gltf", "animation": {"source": "gltf", "clip": "Wave"}})",
                {"/objects/0/animation:", "bending_cylinder.gltf", "no clip named 'Wave'", "0 'Bend'"});
    expectCause(R"({"mesh": "swinging_box.gltf", "animation": "glTF"})", {"/objects/0/animation:", "\"gltf\""});
}

TEST(GltfAnimation, ASkinnedFileDeformsInsideItsTransform) {
    const Scene scene = parseScene(R"({"version": 1, "objects": [{"mesh": "bending_cylinder.gltf", "animation":
             {"source": "gltf", "clip": "Bend", "loop": true}, "transform": {"translation": [1, 2, 3]}}]})",
                                   meshDir(), "test.json");
    const SceneObject& o = scene.objects.at(0);
    ASSERT_TRUE(o.skinAnimation.has_value());
    EXPECT_TRUE(o.skinAnimation->loop);
    EXPECT_FALSE(o.gltfAnimation.has_value()) << "the clip moves bones, not the object";
    EXPECT_TRUE(isAnimated(o));
    EXPECT_EQ(placementAt(o, 0.7), composeTransform({1, 2, 3}, {}, 1.0f)) << "the transform places it at all times";
}
