#include "TestPaths.h"

#include <lightskin/core/Error.h>
#include <lightskin/render/Scene.h>

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <fstream>

using lightskin::Error;
using namespace lightskin::render;

namespace {

std::filesystem::path meshDir() { return lightskin::test::dataPath("meshes"); }

/// The error cause for scene text, or "(no error)".
std::string causeOf(const std::string& text) {
    try {
        parseScene(text, meshDir(), "test.json");
    } catch (const Error& error) {
        EXPECT_EQ(error.source(), "test.json");
        return error.cause();
    }
    return "(no error)";
}

} // namespace

TEST(Scene, SampleScenesLoad) {
    const auto folder = lightskin::test::sourceDir() / "recordings" / "scenes";
    const Scene tabletop = loadScene(folder / "tabletop.json");
    ASSERT_EQ(tabletop.objects.size(), 2u);
    EXPECT_EQ(tabletop.objects[0].name, "bunny");
    EXPECT_TRUE(tabletop.objects[0].mesh.is_absolute());
    EXPECT_TRUE(std::filesystem::exists(tabletop.objects[1].mesh));
    ASSERT_EQ(tabletop.lights.size(), 1u);
    EXPECT_EQ(tabletop.lights[0].type, LightType::Spot);
    EXPECT_NEAR(glm::length(tabletop.lights[0].direction), 1.0f, 1e-6f);
    EXPECT_EQ(tabletop.gi.technique, lightskin::gi::Technique::LightSkin);
    EXPECT_EQ(tabletop.gi.kCache, 128);
    EXPECT_NE(tabletop.trackingJson.find("tag36h11"), std::string::npos);
    ASSERT_TRUE(tabletop.objects[1].material.specularExponent.has_value());
    EXPECT_EQ(*tabletop.objects[1].material.specularExponent, 40.0f);
    EXPECT_EQ(*tabletop.objects[1].material.specularAlbedo, glm::vec3(0.3f));

    const Scene moving = loadScene(folder / "orbit_moving.json"); // the main job's
    ASSERT_EQ(moving.objects.size(), 2u);
    ASSERT_TRUE(moving.objects[1].animation.has_value());
    EXPECT_EQ(moving.objects[1].animation->keys.size(), 3u);

    const Scene cube = loadScene(folder / "cube_no_gi.json");
    EXPECT_EQ(cube.gi.technique, lightskin::gi::Technique::None);
    EXPECT_EQ(cube.lights[0].type, LightType::Point);

    int scenes = 0;
    for (const auto& entry : std::filesystem::directory_iterator(folder))
        if (entry.path().extension() == ".json") {
            EXPECT_NO_THROW(loadScene(entry.path())) << entry.path();
            ++scenes;
        }
    EXPECT_GE(scenes, 3);
    const Scene orbit = loadScene(folder / "orbit.json");
    EXPECT_NE(orbit.trackingJson.find("tag-world.json"), std::string::npos);
    EXPECT_TRUE(std::filesystem::exists(folder / "../synth-orbit/synth/tag-world.json"));
}

TEST(Scene, TransformComposesTranslationRotationScale) {
    const std::string text = R"({"version": 1, "objects": [{"mesh": "box_no_normals.obj",
        "transform": {"translation": [1, 2, 3], "rotationDegrees": [0, 0, 90], "scale": 2}}]})";
    const Scene scene = parseScene(text, meshDir(), "t");
    const glm::vec4 p = scene.objects[0].world_T_model * glm::vec4(1, 0, 0, 1);
    // x axis scaled by 2 and turned 90 degrees about z -> +2 y, then translated.
    EXPECT_NEAR(p.x, 1.0f, 1e-5f);
    EXPECT_NEAR(p.y, 4.0f, 1e-5f);
    EXPECT_NEAR(p.z, 3.0f, 1e-5f);

    const std::string matrix = R"({"version": 1, "objects": [{"mesh": "box_no_normals.obj",
        "transform": {"matrix": [1,0,0,5, 0,1,0,6, 0,0,1,7, 0,0,0,1]}}]})";
    const glm::vec4 q = parseScene(matrix, meshDir(), "t").objects[0].world_T_model * glm::vec4(0, 0, 0, 1);
    EXPECT_EQ(glm::vec3(q), glm::vec3(5, 6, 7)); // row-major in the file
}

TEST(Scene, GiBackendDefaultsToAutoAndAcceptsEachSetting) {
    using lightskin::gi::BackendSetting;
    EXPECT_EQ(parseScene(R"({"version": 1})", meshDir(), "t").gi.backend, BackendSetting::Auto);
    EXPECT_EQ(parseScene(R"({"version": 1, "gi": {}})", meshDir(), "t").gi.backend, BackendSetting::Auto);
    const Scene cpu = parseScene(R"({"version": 1, "gi": {"backend": "cpu"}})", meshDir(), "t");
    EXPECT_EQ(cpu.gi.backend, BackendSetting::Cpu);
    EXPECT_EQ(cpu.gi.technique, lightskin::gi::Technique::LightSkin);
    EXPECT_EQ(parseScene(R"({"version": 1, "gi": {"backend": "gl"}})", meshDir(), "t").gi.backend, BackendSetting::Gl);
    EXPECT_EQ(parseScene(R"({"version": 1, "gi": {"backend": "auto"}})", meshDir(), "t").gi.backend,
              BackendSetting::Auto);
    // A technique without a CPU backend takes "auto" (it resolves to gl) and "gl".
    for (const char* backend : {"auto", "gl"})
        EXPECT_EQ(parseScene(std::string(R"({"version": 1, "gi": {"technique": "brute-force", "backend": ")") +
                                 backend + "\"}}",
                             meshDir(), "t")
                      .gi.backend,
                  *lightskin::gi::parseBackendSetting(backend));
}

TEST(Scene, ErrorsNameTheKeyAndWhatWasExpected) {
    const std::string head = R"({"version": 1, )";
    struct Case {
        std::string text;
        std::string expectedStart;
    };
    const Case cases[] = {
        {head + R"("objects": [{"mesh": "box_no_normals.obj", "material": {"specularExponent": 0.5}}]})",
         "/objects/0/material/specularExponent: expected a number >= 1"},
        {head + R"("objects": [{"mesh": "box_no_normals.obj", "material": {"specularExponent": "shiny"}}]})",
         "/objects/0/material/specularExponent: expected a number >= 1 (Phong exponent k), got \"shiny\""},
        {head + R"("objects": [{"mesh": "no_such_mesh.obj"}]})", "/objects/0/mesh: mesh file '"},
        // A missing texture: named with its key before anything is loaded.
        {head + R"("objects": [{"mesh": "box_no_normals.obj", "material": {"diffuseTexture": "gone.png"}}]})",
         "/objects/0/material/diffuseTexture: texture '"},
        {head + R"("objects": [{"mesh": "box_no_normals.obj", "materail": {}}]})", "/objects/0/materail: unknown key"},
        {head + R"("objects": [{"mesh": "box_no_normals.obj", "material": {"diffuseAlbedo": [1, 2, 0]}}]})",
         "/objects/0/material/diffuseAlbedo/1: expected a number in [0, 1]"},
        {head + R"("lights": [{"type": "area", "position": [0, 0, 1]}]})",
         "/lights/0/type: expected \"point\", \"spot\" or \"estimated\""},
        {head + R"("lights": [{"type": "spot", "position": [0, 0, 1]}]})", "/lights/0/direction: expected a direction"},
        {head + R"("lights": [{"type": "point", "position": [0, 0]}]})",
         "/lights/0/position: expected an array of 3 numbers"},
        {head + R"("gi": {"technique": "magic"}})",
         "/gi/technique: expected \"lightskin\", \"brute-force\", \"imperfect-volumes\", \"multiscale-prt\" or "
         "\"none\""},
        {head + R"("gi": {"backend": "gpu"}})", "/gi/backend: expected \"auto\", \"gl\" or \"cpu\", got \"gpu\""},
        {head + R"("gi": {"backend": "Auto"}})", "/gi/backend: expected \"auto\", \"gl\" or \"cpu\", got \"Auto\""},
        {head + R"("gi": {"backend": 1}})", "/gi/backend: expected a non-empty string, got 1"},
        {head + R"("gi": {"technique": "brute-force", "backend": "cpu"}})",
         "/gi/backend: expected \"auto\" or \"gl\" (the CPU backend exists for technique \"lightskin\" only)"},
        {head + R"("gi": {"kCache": 0}})", "/gi/kCache: expected an integer in [16, 4096]"},
        {head + R"("gi": {"kCache": 100}})", "/gi/kCache: expected a multiple of 16"},
        {head + R"("exposureStops": "bright"})", "/exposureStops: expected a number"},
        {head + R"("compositing": {"differential": "yes"}})", "/compositing/differential: expected true or false"},
        {head + R"("lights": [{"type": "point", "position": [0, 0, 1], "inRoom": 1}]})",
         "/lights/0/inRoom: expected true or false"},
        {head + R"("gi": {"robustRealDepth": 1}})", "/gi/robustRealDepth: expected true or false"},
        {head + R"("gi": {"valTreeThreshold": -0.1}})",
         "/gi/valTreeThreshold: expected a number in [0, 100] or \"auto\""},
        {head + R"("gi": {"valTreeThreshold": "fast"}})",
         "/gi/valTreeThreshold: expected a number in [0, 100] or \"auto\""},
        {R"({"objects": []})", "/version: expected 1"},
        {R"([1, 2])", "/: expected an object"},
        {R"({"version": 1, )", "not valid JSON"},
        {R"({"version": 1e999})", "not valid JSON"}, // number overflow (a fuzz finding: escaped as a json exception)
    };
    for (const Case& c : cases) {
        const std::string cause = causeOf(c.text);
        EXPECT_EQ(cause.rfind(c.expectedStart, 0), 0u) << "scene: " << c.text << "\ncause: " << cause;
    }
}

TEST(Scene, ImperfectVolumesSettingsAreReadAndCheckedByKey) {
    const Scene defaults = parseScene(R"({"version": 1, "gi": {"technique": "imperfect-volumes"}})", meshDir(), "t");
    EXPECT_EQ(defaults.gi.technique, lightskin::gi::Technique::ImperfectVolumes);
    EXPECT_EQ(defaults.gi.imperfectVolumes.resolution, 64); // the paper's 64^3, 12 points, 100 rays
    EXPECT_EQ(defaults.gi.imperfectVolumes.pointsPerTriangle, 12);
    EXPECT_EQ(defaults.gi.imperfectVolumes.raysPerVoxel, 100);
    EXPECT_TRUE(defaults.gi.imperfectVolumes.autoFit);
    const Scene set = parseScene(R"({"version": 1, "gi": {"technique": "imperfect-volumes", "imperfectVolumes":
        {"resolution": 32, "pointsPerTriangle": 6, "raysPerVoxel": 64, "bounces": 3, "ambientOcclusion": true,
         "aoRange": 0.2, "origin": [0, 1, 2], "size": 1.5, "realAlbedo": 0.25, "seed": 9}}})",
                                 meshDir(), "t");
    const auto& v = set.gi.imperfectVolumes;
    EXPECT_EQ(v.resolution, 32);
    EXPECT_EQ(v.pointsPerTriangle, 6);
    EXPECT_EQ(v.raysPerVoxel, 64);
    EXPECT_EQ(v.bounces, 3);
    EXPECT_TRUE(v.ambientOcclusion);
    EXPECT_FLOAT_EQ(v.aoRange, 0.2f);
    EXPECT_FALSE(v.autoFit);
    EXPECT_EQ(v.origin, glm::vec3(0, 1, 2));
    EXPECT_FLOAT_EQ(v.size, 1.5f);
    EXPECT_FLOAT_EQ(v.realAlbedo, 0.25f);
    EXPECT_EQ(v.seed, 9u);

    const std::string head = R"({"version": 1, "gi": {"technique": "imperfect-volumes", "imperfectVolumes": )";
    const std::pair<std::string, std::string> cases[] = {
        {head + R"({"resolution": 257}}})", "/gi/imperfectVolumes/resolution: expected an integer in [1, 256]"},
        {head + R"({"bounces": 0}}})", "/gi/imperfectVolumes/bounces: expected an integer in [1, 4]"},
        {head + R"({"raysPerVoxel": "many"}}})", "/gi/imperfectVolumes/raysPerVoxel: expected an integer"},
        {head + R"({"origin": [0, 0, 0]}}})", "/gi/imperfectVolumes/size: expected both \"origin\" and \"size\""},
        {head + R"({"voxels": 64}}})", "/gi/imperfectVolumes/voxels: unknown key"},
        {head + R"({"realAlbedo": 1.5}}})", "/gi/imperfectVolumes/realAlbedo: expected a number in [0, 1]"},
        {head + R"({"temporalBlend": 1}}})", "/gi/imperfectVolumes/temporalBlend: expected a number in [0, 0.95]"},
        {head + R"({"jitter": 1}}})", "/gi/imperfectVolumes/jitter: expected true or false"},
        {R"({"version": 1, "gi": {"imperfectVolumes": {}}})",
         "/gi/imperfectVolumes: expected gi.technique \"imperfect-volumes\""},
    };
    for (const auto& [text, expectedStart] : cases) {
        const std::string cause = causeOf(text);
        EXPECT_EQ(cause.rfind(expectedStart, 0), 0u) << "scene: " << text << "\ncause: " << cause;
    }
}

TEST(Scene, MultiscalePrtSettingsAreReadAndCheckedByKey) {
    const Scene defaults = parseScene(R"({"version": 1, "gi": {"technique": "multiscale-prt"}})", meshDir(), "t");
    EXPECT_EQ(defaults.gi.multiscalePrt.entryPoints, 512);
    EXPECT_EQ(defaults.gi.multiscalePrt.basisVectors, 8);
    // The cache folder defaults to prt-cache beside the scene file.
    EXPECT_EQ(defaults.gi.multiscalePrt.cacheDirectory, (meshDir() / "prt-cache").lexically_normal());
    const Scene set = parseScene(R"({"version": 1, "gi": {"technique": "multiscale-prt", "multiscalePrt":
        {"entryPoints": 64, "walksPerEntry": 4, "maxBounces": 3, "clusters": 5, "basisVectors": 2,
         "obscuranceDistance": 0.1, "obscuranceRays": 16, "minConnectionDistance": 0.01, "seed": 7,
         "cacheDir": "elsewhere", "entryLightPoints": [[0, 2, 0], [1, 2.5, -1]], "entryLightFraction": 0.5,
         "gatherPoints": 256}}})",
                                 meshDir(), "t");
    const auto& v = set.gi.multiscalePrt;
    EXPECT_EQ(v.entryPoints, 64);
    EXPECT_EQ(v.walksPerEntry, 4);
    EXPECT_EQ(v.maxBounces, 3);
    EXPECT_EQ(v.clusters, 5);
    EXPECT_EQ(v.basisVectors, 2);
    EXPECT_FLOAT_EQ(v.obscuranceDistance, 0.1f);
    EXPECT_EQ(v.obscuranceRays, 16);
    EXPECT_FLOAT_EQ(v.minConnectionDistance, 0.01f);
    EXPECT_EQ(v.seed, 7u);
    EXPECT_EQ(v.cacheDirectory, (meshDir() / "elsewhere").lexically_normal());
    ASSERT_EQ(v.entryLightPoints.size(), 2u);
    EXPECT_EQ(v.entryLightPoints[1], glm::vec3(1.0f, 2.5f, -1.0f));
    EXPECT_FLOAT_EQ(v.entryLightFraction, 0.5f);
    EXPECT_EQ(v.directGatherPoints, 256);
    EXPECT_EQ(defaults.gi.multiscalePrt.directGatherPoints, 1024);
    EXPECT_EQ(defaults.gi.multiscalePrt.entryLightFraction, 0.0f);
    const Scene off = parseScene(
        R"({"version": 1, "gi": {"technique": "multiscale-prt", "multiscalePrt": {"cache": false}}})", meshDir(), "t");
    EXPECT_TRUE(off.gi.multiscalePrt.cacheDirectory.empty());

    const std::string head = R"({"version": 1, "gi": {"technique": "multiscale-prt", "multiscalePrt": )";
    const std::pair<std::string, std::string> cases[] = {
        {head + R"({"entryPoints": 0}}})", "/gi/multiscalePrt/entryPoints: expected an integer in [1, 65536]"},
        {head + R"({"basisVectors": 65}}})", "/gi/multiscalePrt/basisVectors: expected an integer in [0, 64]"},
        {head + R"({"obscuranceDistance": -1}}})",
         "/gi/multiscalePrt/obscuranceDistance: expected a number in [0, 1000]"},
        {head + R"({"atlas": true}}})", "/gi/multiscalePrt/atlas: unknown key"},
        {head + R"({"entryLightFraction": 1}}})",
         "/gi/multiscalePrt/entryLightFraction: expected a number in [0, 0.99]"},
        {head + R"({"entryLightPoints": [[0, 1]]}}})", "/gi/multiscalePrt/entryLightPoints/0: expected"},
        {head + R"({"gatherPoints": -1}}})", "/gi/multiscalePrt/gatherPoints: expected an integer"},
        {head + R"({"cache": false, "cacheDir": "x"}}})", "/gi/multiscalePrt/cacheDir: expected no cacheDir"},
        {R"({"version": 1, "gi": {"multiscalePrt": {}}})",
         "/gi/multiscalePrt: expected gi.technique \"multiscale-prt\""},
    };
    for (const auto& [text, expectedStart] : cases) {
        const std::string cause = causeOf(text);
        EXPECT_EQ(cause.rfind(expectedStart, 0), 0u) << "scene: " << text << "\ncause: " << cause;
    }
}

TEST(Scene, DifferentialIsOnByDefaultAndLightsAreInTheRoom) {
    const Scene defaults =
        parseScene(R"({"version": 1, "lights": [{"type": "point", "position": [0, 0, 1]}]})", ".", "test");
    EXPECT_TRUE(defaults.compositing.differential);
    ASSERT_EQ(defaults.lights.size(), 1u);
    EXPECT_TRUE(defaults.lights[0].inRoom);
    const Scene off = parseScene(
        R"({"version": 1, "compositing": {"differential": false}, "lights": [{"type": "point", "position": [0, 0, 1], "inRoom": false}]})",
        ".", "test");
    EXPECT_FALSE(off.compositing.differential);
    EXPECT_FALSE(off.lights[0].inRoom);
}

TEST(Scene, RobustRealDepthIsTheDefaultAndCanBeTurnedOff) {
    EXPECT_TRUE(parseScene(R"({"version": 1})", meshDir(), "t").gi.robustRealDepth);
    EXPECT_FALSE(parseScene(R"({"version": 1, "gi": {"robustRealDepth": false}})", meshDir(), "t").gi.robustRealDepth);
}

TEST(Scene, ValTreeThresholdIsAutoByDefault) {
    const auto tree = [](const std::string& gi) {
        return parseScene(R"({"version": 1)" + gi + "}", meshDir(), "t").gi.valTreeThreshold;
    };
    EXPECT_EQ(tree(""), std::nullopt);
    EXPECT_EQ(tree(R"(, "gi": {"valTreeThreshold": "auto"})"), std::nullopt);
    EXPECT_EQ(tree(R"(, "gi": {"valTreeThreshold": 0.05})"), 0.05f);
    EXPECT_EQ(tree(R"(, "gi": {"valTreeThreshold": 0})"), 0.0f) << "0: the flat gather, not auto";
}

TEST(Scene, MissingFileIsAnError) {
    EXPECT_THROW(loadScene(lightskin::test::scratchDir("scene_missing") / "nope.json"), Error);
}

TEST(Scene, AnimationKeysAreReadInTheTransformsWordsAndPlaceTheObjectAtTheirStart) {
    const Scene scene = parseScene(R"({"version": 1,
        "objects": [{"mesh": "box_no_normals.obj", "visible": false, "animation": {"loop": true, "keys": [
            {"t": 0.5, "translation": [1, 2, 3], "rotationDegrees": [0, 0, 90], "scale": 2},
            {"t": 2.5, "translation": [3, 2, 1]}]}}],
        "lights": [{"type": "spot", "position": [0, 0, 2], "direction": [0, 0, -1], "power": 40,
                    "animation": {"keys": [{"t": 0, "power": 0}, {"t": 1, "position": [1, 0, 2], "direction": [1, 0, 0]}]}}]})",
                                   meshDir(), "test.json");
    const SceneObject& o = scene.objects.at(0);
    ASSERT_TRUE(o.animation.has_value());
    EXPECT_TRUE(o.animation->loop);
    EXPECT_FALSE(o.visible);
    ASSERT_EQ(o.animation->keys.size(), 2u);
    EXPECT_EQ(o.animation->keys[1].timeSeconds, 2.5);
    EXPECT_EQ(o.animation->keys[1].scale, 1.0f) << "a key's missing scale is 1";
    // Before the first key: the first key's placement, also as the object's static placement.
    const glm::mat4 first = composeTransform({1, 2, 3}, {0, 0, 90}, 2.0f);
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) EXPECT_NEAR(o.world_T_model[c][r], first[c][r], 2e-6f);
    const SceneLight& l = scene.lights.at(0);
    ASSERT_TRUE(l.animation.has_value());
    // A key's missing values are the light's own.
    EXPECT_EQ(l.animation->keys[0].position, glm::vec3(0, 0, 2));
    EXPECT_EQ(l.animation->keys[0].power, glm::vec3(0.0f));
    EXPECT_EQ(l.animation->keys[1].power, glm::vec3(40.0f));
    EXPECT_EQ(l.animation->keys[1].direction, glm::vec3(1, 0, 0));
    EXPECT_EQ(l.power, glm::vec3(0.0f)) << "an animated light starts at its first key";
}

TEST(Scene, AnimationErrorsNameTheKey) {
    const std::string object = R"({"version": 1, "objects": [{"mesh": "box_no_normals.obj", )";
    const std::string light = R"({"version": 1, "lights": [{"type": "point", "position": [0, 0, 1], )";
    struct Case {
        std::string text;
        std::string expectedStart;
    };
    const Case cases[] = {
        {object + R"("animation": {"keys": []}}]})", "/objects/0/animation/keys: expected an array of 1 to"},
        {object + R"("animation": {"keys": [{"t": 1}, {"t": 1}]}}]})",
         "/objects/0/animation/keys/1/t: expected a time after the previous key's"},
        {object + R"("animation": {"keys": [{"t": -1}]}}]})", "/objects/0/animation/keys/0/t: expected a number >= 0"},
        {object + R"("animation": {"keys": [{"translation": [0, 0, 0]}]}}]})",
         "/objects/0/animation/keys/0/t: expected"},
        {object + R"("animation": {"keys": [{"t": 0, "scale": 0}]}}]})", "/objects/0/animation/keys/0/scale: expected"},
        {object + R"("animation": {"keys": [{"t": 0, "position": [0, 0, 0]}]}}]})",
         "/objects/0/animation/keys/0/position: unknown key"},
        {object + R"("animation": {"keys": [{"t": 0}], "loop": true}}]})",
         "/objects/0/animation/loop: expected at least two keys"},
        {object + R"("transform": {"scale": 2}, "animation": {"keys": [{"t": 0}]}}]})",
         "/objects/0/animation: expected either \"transform\" or \"animation\""},
        {object + R"("animation": "gltf"}]})", "/objects/0/animation: expected an animation the mesh file can play"},
        {object + R"("visible": "no"}]})", "/objects/0/visible: expected true or false"},
        {light + R"("animation": {"keys": [{"t": 0, "direction": [1, 0, 0]}]}}]})",
         "/lights/0/animation/keys/0/direction: expected no direction on a point light"},
        {light + R"("animation": {"keys": [{"t": 0, "power": -1}]}}]})",
         "/lights/0/animation/keys/0/power: expected a number >= 0"},
    };
    for (const Case& c : cases) {
        const std::string cause = causeOf(c.text);
        EXPECT_EQ(cause.rfind(c.expectedStart, 0), 0u) << "scene: " << c.text << "\ncause: " << cause;
    }
}

TEST(Scene, AnEstimatedLightIsReadWithItsSettings) {
    const Scene defaults = parseScene(
        R"({"version": 1, "lights": [{"type": "point", "position": [0, 0, 1]}, {"type": "estimated"}]})", ".", "t");
    ASSERT_EQ(defaults.lights.size(), 2u);
    const SceneLight& e = defaults.lights[1];
    EXPECT_EQ(e.type, LightType::Estimated);
    EXPECT_TRUE(e.inRoom);               // the room's own light: only the objects' shadows change the real surfaces
    EXPECT_TRUE(e.castsShadows);         // as every light by default
    EXPECT_EQ(e.power, glm::vec3(0.0f)); // dark until the first estimate
    EXPECT_EQ(e.estimation.stride, 8);
    EXPECT_EQ(e.estimation.fitInterval, 3);
    EXPECT_DOUBLE_EQ(e.estimation.timeConstantSeconds, 0.25);
    EXPECT_DOUBLE_EQ(e.estimation.referenceAlbedo, 0.5);
    EXPECT_FLOAT_EQ(e.estimation.distantLightMetres, 5.0f);

    const Scene set = parseScene(
        R"({"version": 1, "lights": [{"type": "estimated", "shadows": false, "stride": 4, "fitInterval": 1,
            "timeConstantSeconds": 0.5, "referenceAlbedo": 0.6, "distantLightMetres": 3}]})",
        ".", "t");
    const EstimatedLightSettings& s = set.lights[0].estimation;
    EXPECT_FALSE(set.lights[0].castsShadows);
    EXPECT_EQ(s.stride, 4);
    EXPECT_EQ(s.fitInterval, 1);
    EXPECT_DOUBLE_EQ(s.timeConstantSeconds, 0.5);
    EXPECT_NEAR(s.referenceAlbedo, 0.6, 1e-7);
    EXPECT_FLOAT_EQ(s.distantLightMetres, 3.0f);
}

TEST(Scene, EstimatedLightErrorsNameTheKey) {
    const std::string head = R"({"version": 1, "lights": [)";
    const std::pair<std::string, std::string> cases[] = {
        {head + R"({"type": "estimated"}, {"type": "point", "position": [0, 0, 1]}, {"type": "estimated"}]})",
         "/lights/2/type: expected at most one light of type \"estimated\" (lights/0 is one already)"},
        // Position and power come from the estimate, inRoom is always true: such keys are typos or misunderstandings.
        {head + R"({"type": "estimated", "power": 10}]})", "/lights/0/power: unknown key"},
        {head + R"({"type": "estimated", "position": [0, 0, 1]}]})", "/lights/0/position: unknown key"},
        {head + R"({"type": "estimated", "inRoom": false}]})", "/lights/0/inRoom: unknown key"},
        {head + R"({"type": "estimated", "stride": 0}]})", "/lights/0/stride: expected an integer in [1, 64]"},
        {head + R"({"type": "estimated", "stride": 2.5}]})", "/lights/0/stride: expected an integer in [1, 64]"},
        {head + R"({"type": "estimated", "fitInterval": 0}]})",
         "/lights/0/fitInterval: expected an integer in [1, 300]"},
        {head + R"({"type": "estimated", "timeConstantSeconds": -1}]})",
         "/lights/0/timeConstantSeconds: expected a number in [0, 3600]"},
        {head + R"({"type": "estimated", "referenceAlbedo": 1.5}]})",
         "/lights/0/referenceAlbedo: expected a number in [0.01, 1]"},
        {head + R"({"type": "estimated", "distantLightMetres": 100}]})",
         "/lights/0/distantLightMetres: expected a number in [0.5, 15]"},
        {head + R"({"type": "estimated", "shadows": "yes"}]})", "/lights/0/shadows: expected true or false"},
        {head + R"({"type": "Estimated"}]})", "/lights/0/type: expected \"point\", \"spot\" or \"estimated\""},
    };
    for (const auto& [text, expectedStart] : cases) {
        const std::string cause = causeOf(text);
        EXPECT_EQ(cause.rfind(expectedStart, 0), 0u) << "scene: " << text << "\ncause: " << cause;
    }
}
