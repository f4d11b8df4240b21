// gi::MultiscalePrt as an IndirectIllumination technique on GL: the target holds rho_d / pi times the exit
// irradiance interpolated over the triangles (checked per pixel against a separately written barycentric
// interpolation), an empty VAL set gives exactly 0, and the precompute cache is written, loaded (with the
// same images) and, when corrupt, recomputed with a warning instead of a crash.
#include "GlTestEnvironment.h"
#include "PrtScenes.h"

#include <lightskin/gi/prt/MultiscalePrt.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/gl/Readback.h>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <filesystem>
#include <fstream>
#include <numbers>

namespace lightskin::test {
namespace {

constexpr int kCells = 4, kSize = 96;

// A floor [0, 1]^2 (z = 0, kCells^2 quads) and a white wall at x = 1 facing it, VALs above.
struct Rig {
    prt::PrtScene scene;
    std::vector<gi::UploadedMesh> gpu;
    std::vector<gi::VirtualAreaLight> vals;
    gl::Buffer valBuffer;
    gi::SimpleGBuffer gbuffer;
    gl::Texture output;
    glm::vec3 eye{0.5f, -0.6f, 1.6f};
    glm::mat4 clip_T_world{1.0f};

    Rig() {
        scene.add(prt::quadGrid({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, kCells), glm::vec3(0.5f, 0.6f, 0.7f));
        scene.add(prt::quadGrid({1, 0, 0}, {0, 0, 1}, {0, 1, 0}, kCells), glm::vec3(0.9f, 0.3f, 0.1f));
        for (std::size_t i = 0; i < scene.instances.size(); ++i) {
            gpu.push_back(gi::UploadedMesh::create(scene.meshes[i]));
            scene.instances[i].gpu = gpu.back().view();
        }
        for (int i = 0; i < 4; ++i)
            vals.push_back({{0.2f + 0.2f * float(i), 0.5f, 1.2f}, 0.02f, {0, 0, -1}, 0.0f, {0.5f, 0.5f, 0.5f}, 0.0f});
        valBuffer = gl::Buffer::create(GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)), vals.data());
        gbuffer = gi::SimpleGBuffer::create(kSize, kSize);
        output = gl::Texture::create2D(GL_RGBA32F, kSize, kSize);
        clip_T_world = glm::perspective(1.0f, 1.0f, 0.01f, 100.0f) *
                       glm::lookAt(eye, glm::vec3(0.5f, 0.5f, 0.0f), glm::vec3(0, 0, 1));
        gbuffer.render(scene.instances, clip_T_world);
    }
    cv::Mat render(gi::MultiscalePrt& prt, std::uint32_t valCount) {
        prt.render({valBuffer.id(), valCount}, scene.instances, gbuffer.view(), {clip_T_world, eye}, output.id());
        cv::Mat image;
        gl::readTextureRgba32fInto(output, image);
        return image;
    }
};

gi::MultiscalePrtSettings smallSettings(const std::filesystem::path& cache = {}) {
    gi::MultiscalePrtSettings s;
    s.entryPoints = 64;
    s.walksPerEntry = 8;
    s.clusters = 4;
    s.basisVectors = 4;
    s.cacheDirectory = cache;
    return s;
}

using MultiscalePrtGLTest = GlTest;

TEST_F(MultiscalePrtGLTest, TargetIsAlbedoOverPiTimesTheInterpolatedExitIrradiance) {
    Rig rig;
    auto prt = gi::MultiscalePrt::create(smallSettings());
    prt->prepare(rig.scene.instances);
    const cv::Mat image = rig.render(*prt, std::uint32_t(rig.vals.size()));
    const std::span<const glm::vec3> exit = prt->lastExitIrradiance();
    ASSERT_EQ(exit.size(), 2u * (kCells + 1) * (kCells + 1));
    // The wall's light reaches the floor: the transfer is not zero (its bounce adds to the floor's exits).
    cv::Mat position;
    gl::readTextureRgba32fInto(rig.gbuffer.position(), position);
    const glm::vec3 albedo = rig.scene.instances[0].material.diffuseAlbedo;
    int checked = 0;
    double maxValue = 0.0;
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
            const cv::Vec4f p = position.at<cv::Vec4f>(y, x);
            const cv::Vec4f out = image.at<cv::Vec4f>(y, x);
            if (p[3] == 0.0f) {
                EXPECT_EQ(out, cv::Vec4f(0, 0, 0, 0)) << "uncovered pixel " << x << ", " << y;
                continue;
            }
            if (std::abs(p[2]) > 1e-4f || p[0] > 0.999f) continue; // the floor only (not the wall)
            // Barycentric interpolation over the grid's triangles (00, 10, 11) and (00, 11, 01).
            const float gx = std::clamp(p[0] * kCells, 0.0f, float(kCells) - 1e-4f);
            const float gy = std::clamp(p[1] * kCells, 0.0f, float(kCells) - 1e-4f);
            const int i = int(gx), j = int(gy);
            const float u = gx - float(i), v = gy - float(j);
            const auto at = [&](int a, int b) { return exit[std::size_t(b * (kCells + 1) + a)]; };
            const glm::vec3 e = u >= v ? (1 - u) * at(i, j) + (u - v) * at(i + 1, j) + v * at(i + 1, j + 1)
                                       : (1 - v) * at(i, j) + (v - u) * at(i, j + 1) + u * at(i + 1, j + 1);
            const glm::vec3 expected = albedo / std::numbers::pi_v<float> * e;
            for (int c = 0; c < 3; ++c) {
                // Float interpolation on the GPU (perspective-correct, exact for an affine attribute up to
                // rounding) and the G-buffer position's float error (~1e-6 m in the cell coordinates): 1e-3
                // relative covers both by far, a wrong vertex or a missing 1/pi does not fit.
                EXPECT_NEAR(out[c], expected[c], 1e-3f * expected[c] + 1e-7f) << "pixel " << x << ", " << y;
                maxValue = std::max(maxValue, double(out[c]));
            }
            ++checked;
        }
    EXPECT_GT(checked, kSize * kSize / 8);
    EXPECT_GT(maxValue, 0.0);
    std::vector<gl::StageTime> times;
    prt->lastStageTimes(times);
    ASSERT_EQ(times.size(), 5u);
    EXPECT_EQ(times[1].name, "entry");
    EXPECT_EQ(times[2].name, "lights");

    const cv::Mat dark = rig.render(*prt, 0);
    EXPECT_EQ(cv::countNonZero(dark.reshape(1) != 0.0f), 0) << "no VALs and no lights: exactly 0";
}

TEST_F(MultiscalePrtGLTest, CacheIsWrittenLoadedAndRecomputedWhenCorrupt) {
    Rig rig;
    const auto folder = std::filesystem::temp_directory_path() / "lightskin_prt_gl_cache";
    std::filesystem::remove_all(folder);
    auto first = gi::MultiscalePrt::create(smallSettings(folder));
    first->prepare(rig.scene.instances);
    EXPECT_FALSE(first->loadedFromCache());
    ASSERT_TRUE(std::filesystem::exists(first->cacheFile())) << first->cacheFile();
    const cv::Mat reference = rig.render(*first, std::uint32_t(rig.vals.size()));

    auto second = gi::MultiscalePrt::create(smallSettings(folder));
    second->prepare(rig.scene.instances);
    EXPECT_TRUE(second->loadedFromCache());
    EXPECT_EQ(second->data().clusterMaps, first->data().clusterMaps);
    const cv::Mat loaded = rig.render(*second, std::uint32_t(rig.vals.size()));
    EXPECT_EQ(cv::countNonZero(loaded.reshape(1) != reference.reshape(1)), 0) << "the cached transfer is the same";

    // Truncated cache: a warning, a recompute, the file rewritten (the next technique loads it again).
    const auto size = std::filesystem::file_size(first->cacheFile());
    std::filesystem::resize_file(first->cacheFile(), size / 2);
    auto third = gi::MultiscalePrt::create(smallSettings(folder));
    third->prepare(rig.scene.instances);
    EXPECT_FALSE(third->loadedFromCache());
    EXPECT_EQ(std::filesystem::file_size(first->cacheFile()), size);
    const cv::Mat recomputed = rig.render(*third, std::uint32_t(rig.vals.size()));
    EXPECT_EQ(cv::countNonZero(recomputed.reshape(1) != reference.reshape(1)), 0) << "deterministic precompute";
    auto fourth = gi::MultiscalePrt::create(smallSettings(folder));
    fourth->prepare(rig.scene.instances);
    EXPECT_TRUE(fourth->loadedFromCache());
    std::filesystem::remove_all(folder);
}

} // namespace
} // namespace lightskin::test
