// A scene without virtual objects is valid (the real room alone, or objects added later through the API), for
// every technique on every backend it runs on, used directly through the library as a host would: prepare()
// takes an empty instance list, and render() then writes exactly 0 to every pixel of its target, with no VAL
// and with VALs, without a GL error. The target holds 7 before each render, so a render that writes nothing
// fails. Afterwards the same technique prepares and renders a real mesh lit by the same VALs: an empty scene
// leaves it usable.
#include "GlTestEnvironment.h"
#include "TestMeshes.h"

#include <lightskin/gi/Techniques.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/gl/Readback.h>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <string>
#include <vector>

using namespace lightskin;

namespace {

constexpr int kWidth = 40, kHeight = 30;
constexpr float kBefore = 7.0f; // what the target holds before a render

struct Case {
    gi::Technique technique;
    gi::Backend backend;
};

std::vector<Case> everyTechniqueOnEveryBackend() {
    std::vector<Case> cases;
    for (gi::Technique technique : gi::kTechniques)
        for (gi::Backend backend : gi::kBackends)
            if (gi::runsOn(technique, backend)) cases.push_back({technique, backend});
    return cases;
}

std::string caseName(const ::testing::TestParamInfo<Case>& param) {
    std::string name =
        std::string(gi::toString(param.param.technique)) + "_" + std::string(gi::toString(param.param.backend));
    for (char& c : name)
        if (c == '-') c = '_';
    return name;
}

// A 4 x 4 patch of upward-facing VALs on the floor (z = 0), 1 cm^2 each, 10 cm under the mesh of the second part.
std::vector<gi::VirtualAreaLight> floorVals() {
    std::vector<gi::VirtualAreaLight> vals;
    for (int i = 0; i < 16; ++i) {
        gi::VirtualAreaLight val;
        val.position = glm::vec3(-0.15f + 0.1f * float(i % 4), -0.15f + 0.1f * float(i / 4), 0.0f);
        val.area = 1e-2f;
        val.normal = glm::vec3(0.0f, 0.0f, 1.0f);
        val.flux = glm::vec3(0.05f);
        vals.push_back(val);
    }
    return vals;
}

struct Counts {
    int exactlyZero = 0, nonFinite = 0, positive = 0, total = 0;
};

Counts countTarget(const gl::Texture& target) {
    cv::Mat image;
    gl::readTextureRgba32fInto(target, image);
    Counts counts;
    for (int y = 0; y < image.rows; ++y)
        for (int x = 0; x < image.cols; ++x) {
            const cv::Vec4f p = image.at<cv::Vec4f>(y, x);
            const bool zero = p[0] == 0.0f && p[1] == 0.0f && p[2] == 0.0f;
            const bool finite = std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
            counts.exactlyZero += zero ? 1 : 0;
            counts.nonFinite += finite ? 0 : 1;
            counts.positive += finite && (p[0] > 0.0f || p[1] > 0.0f || p[2] > 0.0f) ? 1 : 0;
            ++counts.total;
        }
    return counts;
}

void fillTarget(const gl::Texture& target) {
    const float value[4] = {kBefore, kBefore, kBefore, kBefore};
    glClearTexImage(target.id(), 0, GL_RGBA, GL_FLOAT, value);
}

class EmptySceneGLTest : public test::GlTest, public ::testing::WithParamInterface<Case> {};

TEST_P(EmptySceneGLTest, PreparesNoInstanceRendersZeroAndThenLightsARealMesh) {
    gi::GiSettings settings;
    settings.technique = GetParam().technique;
    settings.backend = gi::settingOf(GetParam().backend);
    settings.sparsePoints = 64;
    // A 40 cm square 10 cm above the VALs, facing down at them; the camera looks up at it from below.
    const TriangleMesh mesh =
        test::quadGrid(glm::vec3(-0.2f, -0.2f, 0.1f), glm::vec3(0.0f, 0.4f, 0.0f), glm::vec3(0.4f, 0.0f, 0.0f), 8);
    gi::MeshInstance instance;
    instance.mesh = &mesh;
    instance.material.diffuseAlbedo = glm::vec3(0.8f);
    gi::SparsePointSettings sparse;
    sparse.pointCount = settings.sparsePoints;
    const auto technique = gi::createTechnique(gi::configFor(settings), [&](const gi::MeshInstance&) {
        return gi::sampleSparsePoints(mesh, sparse, "empty-scene test mesh");
    });

    const std::vector<gi::VirtualAreaLight> vals = floorVals();
    const gl::Buffer valBuffer =
        gl::Buffer::create(GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)), vals.data(), 0);
    const gi::ValSetView noVals{};
    const gi::ValSetView someVals{valBuffer.id(), std::uint32_t(vals.size()), 1};
    const glm::vec3 eye(0.0f, -0.3f, -0.25f);
    const glm::mat4 clip = glm::perspective(0.9f, float(kWidth) / float(kHeight), 0.01f, 10.0f) *
                           glm::lookAt(eye, glm::vec3(0.0f, 0.0f, 0.1f), glm::vec3(0.0f, 0.0f, 1.0f));
    const gi::ViewParameters view(clip, eye);
    gi::SimpleGBuffer gbuffer = gi::SimpleGBuffer::create(kWidth, kHeight);
    const gl::Texture target = gl::Texture::create2D(GL_RGBA32F, kWidth, kHeight);

    technique->prepare({});
    gbuffer.render({}, clip);
    for (const gi::ValSetView* set : {&noVals, &someVals}) {
        fillTarget(target);
        technique->render(*set, {}, gbuffer.view(), view, target.id());
        const Counts counts = countTarget(target);
        EXPECT_EQ(counts.exactlyZero, counts.total) << set->count << " VALs, no instance: every pixel must be 0";
        std::vector<gl::StageTime> stages;
        technique->lastStageTimes(stages);
        std::vector<glm::vec4> vertexVpls;
        technique->readVertexVpls(vertexVpls);
        EXPECT_TRUE(vertexVpls.empty());
    }

    // The same technique with real content afterwards: the mesh covers part of the image and gets light there.
    gi::UploadedMesh uploaded = gi::UploadedMesh::create(mesh);
    instance.gpu = uploaded.view();
    const std::vector<gi::MeshInstance> instances{instance};
    technique->prepare(instances);
    gbuffer.render(instances, clip);
    fillTarget(target);
    technique->render(someVals, instances, gbuffer.view(), view, target.id());
    const Counts counts = countTarget(target);
    EXPECT_EQ(counts.nonFinite, 0);
    if (GetParam().technique != gi::Technique::None) {
        EXPECT_GT(counts.positive, 0) << "the mesh after an empty scene got no indirect light";
        EXPECT_GT(counts.exactlyZero, 0) << "pixels without the mesh must be 0";
    }
}

INSTANTIATE_TEST_SUITE_P(EveryTechnique, EmptySceneGLTest, ::testing::ValuesIn(everyTechniqueOnEveryBackend()),
                         caseName);

} // namespace
