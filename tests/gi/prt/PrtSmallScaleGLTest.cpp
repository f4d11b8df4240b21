// Multi-scale PRT's small scale (gi/prt/include/lightskin/gi/prt/MultiscalePrt.h, "Small scale") on the
// tiles of recordings/scenes/meshes/make_ao_tile.py: a flat unit quad lit by four VAL discs, seen from above.
// - occlusion map: the indirect target is rho_d / pi * E * (1 + strength (R - 1)) texel for texel, E the VALs' disc
//   form factor (written here in double: a single plane has no transfer and obscuranceDistance = 0 gives W = 1),
//   R decoded here from the PNG by glTF's rule (uv (0, 0) = the image's top-left);
// - normal map only: S = (1 + cos alpha) / 2 of the mapped normal (alpha from the PNG's bytes and the 0.5 scale),
//   1 where the map is flat;
// - through the renderer: the direct light of the tile with maps is bitwise the one without, and the composite
//   minus the direct light is the plain tile's indirect light times S;
// - maps on a mesh without texture coordinates are off (S = 1);
// - a map file that exists but is no image: prepare() fails naming it.
#include "GlTestEnvironment.h"
#include "TestPaths.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/Pose.h>
#include <lightskin/gi/prt/MultiscalePrt.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/gl/Readback.h>
#include <lightskin/render/MeshLoader.h>
#include <lightskin/render/Renderer.h>
#include <lightskin/render/Scene.h>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <optional>

namespace lightskin::test {
namespace {

constexpr int kSize = 128;
const std::filesystem::path kMeshes = "recordings/scenes/meshes";

// The map's texel (8 x 8 image, 2 x 2-texel cells) under world point (x, y) of the tile by glTF's uv rule, or
// nothing within 0.55 texels of a cell border: there bilinear filtering blends two cells, inside a cell the four
// texels it blends are equal (0.05 texel beyond the exact 0.5: G-buffer position rounding, ~1e-6 texel).
std::optional<cv::Vec3b> cellTexel(const cv::Mat& bgr, float x, float y) {
    const float column = x * float(bgr.cols), row = (1.0f - y) * float(bgr.rows); // uv = (x, 1 - y) in the file
    for (float p : {column, row}) {
        const float inCell = p - 2.0f * std::floor(p / 2.0f);
        if (inCell < 0.55f || inCell > 1.45f) return std::nullopt;
    }
    const int c = std::clamp(int(column), 0, bgr.cols - 1), r = std::clamp(int(row), 0, bgr.rows - 1);
    return bgr.at<cv::Vec3b>(r, c);
}

// Four VAL discs 0.8-1.3 m above the tile facing down, different colours so that every channel is tested.
std::vector<gi::VirtualAreaLight> testVals() {
    std::vector<gi::VirtualAreaLight> vals;
    for (int i = 0; i < 4; ++i)
        vals.push_back({{0.2f + 0.3f * float(i % 2), 0.3f + 0.4f * float(i / 2), 0.8f + 0.15f * float(i)},
                        0.01f,
                        glm::normalize(glm::vec3(0.1f * float(i) - 0.15f, 0.05f, -1.0f)),
                        0.0f,
                        {0.6f + 0.1f * float(i), 0.4f, 0.8f - 0.1f * float(i)},
                        0.0f});
    return vals;
}

// The disc form factor of docs/LIGHTSKIN.md ("Per frame"), in double: E = sum phi cos_j cos_p / (pi d^2 + A).
glm::dvec3 valIrradiance(const std::vector<gi::VirtualAreaLight>& vals, glm::dvec3 p, glm::dvec3 n) {
    glm::dvec3 e(0.0);
    for (const gi::VirtualAreaLight& val : vals) {
        const glm::dvec3 d = glm::dvec3(val.position) - p;
        const double d2 = glm::dot(d, d), length = std::sqrt(d2);
        const double cosP = glm::dot(n, d) / length, cosJ = -glm::dot(glm::dvec3(val.normal), d) / length;
        if (cosP <= 0.0 || cosJ <= 0.0) continue;
        e += glm::dvec3(val.flux) * (cosP * cosJ / (std::numbers::pi * d2 + double(val.area)));
    }
    return e;
}

gi::MultiscalePrtSettings settings() {
    gi::MultiscalePrtSettings s;
    s.entryPoints = 32;
    s.walksPerEntry = 4;
    s.clusters = 2;
    s.basisVectors = 2;
    return s;
}

// One tile from a make_ao_tile.py glTF, drawn into a SimpleGBuffer from 1.2 m above its centre.
struct TileRig {
    TriangleMesh mesh;
    gi::MeshInstance instance;
    gi::UploadedMesh gpu;
    std::vector<gi::VirtualAreaLight> vals = testVals();
    gl::Buffer valBuffer;
    gi::SimpleGBuffer gbuffer;
    gl::Texture output;
    glm::vec3 eye{0.5f, 0.5f, 1.2f};
    glm::mat4 clip_T_world{1.0f};

    explicit TileRig(const std::string& file, bool withTexcoords = true) {
        const render::LoadedModel model = render::loadModel(sourceDir() / kMeshes / file);
        EXPECT_EQ(model.parts.size(), 1u);
        mesh = model.parts[0].mesh;
        if (!withTexcoords) mesh.texcoords.clear();
        instance.mesh = &mesh;
        instance.material = model.parts[0].material;
        instance.material.diffuseAlbedo = glm::vec3(0.9f, 0.6f, 0.3f);
        gpu = gi::UploadedMesh::create(mesh);
        instance.gpu = gpu.view();
        valBuffer = gl::Buffer::create(GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)), vals.data());
        gbuffer = gi::SimpleGBuffer::create(kSize, kSize);
        output = gl::Texture::create2D(GL_RGBA32F, kSize, kSize);
        clip_T_world = glm::perspective(1.0f, 1.0f, 0.01f, 100.0f) *
                       glm::lookAt(eye, glm::vec3(0.5f, 0.5f, 0.0f), glm::vec3(0, 1, 0));
        gbuffer.render({&instance, 1}, clip_T_world);
    }
    /// The indirect target of a technique prepared for `material` (CV_32FC4, GL row order).
    cv::Mat render(const Material& material) {
        gi::MeshInstance shaded = instance;
        shaded.material = material;
        auto prt = gi::MultiscalePrt::create(settings());
        prt->prepare({&shaded, 1});
        prt->render({valBuffer.id(), std::uint32_t(vals.size())}, {&shaded, 1}, gbuffer.view(), {clip_T_world, eye},
                    output.id());
        cv::Mat image;
        gl::readTextureRgba32fInto(output, image);
        return image;
    }
    cv::Mat positions() const {
        cv::Mat position;
        gl::readTextureRgba32fInto(gbuffer.position(), position);
        return position;
    }
};

Material withoutMaps(Material material) {
    material.occlusionTexture.clear();
    material.normalTexture.clear();
    return material;
}

cv::Mat readPng(const std::string& name) {
    const cv::Mat bgr = cv::imread((sourceDir() / kMeshes / name).string(), cv::IMREAD_COLOR);
    EXPECT_FALSE(bgr.empty()) << name;
    return bgr;
}

using PrtSmallScaleGLTest = GlTest;

TEST_F(PrtSmallScaleGLTest, OcclusionMapMultipliesTheIndirectLightTexelForTexel) {
    TileRig rig("ao_tile.gltf");
    ASSERT_FALSE(rig.instance.material.occlusionTexture.empty());
    const float strength = rig.instance.material.occlusionStrength;
    ASSERT_EQ(strength, 0.75f);
    const cv::Mat occlusion = readPng("ao_tile_occlusion.png");
    const cv::Mat image = rig.render(rig.instance.material);
    const cv::Mat position = rig.positions();
    const glm::vec3 albedo = rig.instance.material.diffuseAlbedo;
    // E at the 9 x 9 vertices, interpolated like the rasteriser over the grid's triangles (00, 10, 11), (00, 11, 01).
    constexpr int cells = 8;
    const auto vertexE = [&](int i, int j) {
        return valIrradiance(rig.vals, {double(i) / cells, double(j) / cells, 0.0}, {0.0, 0.0, 1.0});
    };
    std::array<int, 256> seen{};
    int checked = 0;
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
            const cv::Vec4f p = position.at<cv::Vec4f>(y, x);
            if (p[3] == 0.0f) continue;
            const std::optional<cv::Vec3b> texel = cellTexel(occlusion, p[0], p[1]);
            if (!texel) continue;
            const float gx = std::clamp(p[0] * cells, 0.0f, float(cells) - 1e-4f);
            const float gy = std::clamp(p[1] * cells, 0.0f, float(cells) - 1e-4f);
            const int i = int(gx), j = int(gy);
            const double u = gx - float(i), v = gy - float(j);
            const glm::dvec3 e =
                u >= v ? (1 - u) * vertexE(i, j) + (u - v) * vertexE(i + 1, j) + v * vertexE(i + 1, j + 1)
                       : (1 - v) * vertexE(i, j) + (v - u) * vertexE(i, j + 1) + u * vertexE(i + 1, j + 1);
            const double ao = 1.0 + double(strength) * ((*texel)[2] / 255.0 - 1.0); // glTF: the red channel
            const cv::Vec4f out = image.at<cv::Vec4f>(y, x);
            for (int c = 0; c < 3; ++c) {
                const double expected = double(albedo[c]) / std::numbers::pi * e[c] * ao;
                // 2e-3 relative: the float E and its interpolation (1e-3, as gi_prt_gl_test), the 16-bit texel
                // (exact for 8-bit data) and a transfer that is zero up to the PCA's rounding (one plane cannot
                // see itself). A wrong cell (AO 0.63 / 0.81 / 1.0 differ by > 19 %) or AO twice does not fit.
                EXPECT_NEAR(out[c], expected, 2e-3 * expected) << "pixel " << x << ", " << y;
            }
            ++seen[(*texel)[2]];
            ++checked;
        }
    // Every level of the map was checked, the top-left cell's 64 included (a flipped lookup fails there).
    EXPECT_GT(seen[64], 20);
    EXPECT_GT(seen[128], 100);
    EXPECT_GT(seen[255], 100);
    EXPECT_GT(checked, kSize * kSize / 10);
}

TEST_F(PrtSmallScaleGLTest, NormalMapOnlyGivesHalfOnePlusCosAlphaAndOneWhereFlat) {
    TileRig rig("normal_tile.gltf");
    const Material& material = rig.instance.material;
    ASSERT_TRUE(material.occlusionTexture.empty());
    ASSERT_FALSE(material.normalTexture.empty());
    ASSERT_EQ(material.normalScale, 0.5f);
    const cv::Mat normals = readPng("ao_tile_normal.png");
    const cv::Mat mapped = rig.render(material), plain = rig.render(withoutMaps(material));
    const cv::Mat position = rig.positions();
    int flat = 0, tilted = 0;
    double minimum = 1.0;
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
            const cv::Vec4f p = position.at<cv::Vec4f>(y, x);
            if (p[3] == 0.0f) continue;
            const std::optional<cv::Vec3b> texel = cellTexel(normals, p[0], p[1]);
            if (!texel) continue;
            // glTF: n = 2 byte / 255 - 1 (x = R, y = G, z = B), x and y times the scale, normalised.
            const glm::dvec3 n(0.5 * (2.0 * (*texel)[2] / 255.0 - 1.0), 0.5 * (2.0 * (*texel)[1] / 255.0 - 1.0),
                               2.0 * (*texel)[0] / 255.0 - 1.0);
            const double expected = 0.5 * (1.0 + n.z / glm::length(n)); // the paper's W(alpha, h = 1)
            const bool isFlat = (*texel)[2] == 128 && (*texel)[1] == 128;
            (isFlat ? flat : tilted) += 1;
            if (isFlat) {
                // A flat map's bytes (128, 128, 255) give cos alpha = 1 - 1.5e-5: S = 1 to 1e-5.
                EXPECT_NEAR(expected, 1.0, 1e-5);
            }
            minimum = std::min(minimum, expected);
            const cv::Vec4f a = mapped.at<cv::Vec4f>(y, x), b = plain.at<cv::Vec4f>(y, x);
            for (int c = 0; c < 3; ++c) {
                ASSERT_GT(b[c], 0.0f) << "the plain tile is lit at " << x << ", " << y;
                // Same technique and VALs on both sides: only S differs; float rounding of one product (1e-6)
                // and the 16-bit texel (exact for 8-bit data) are far below 1e-4. The 60-degree tilt at scale
                // 0.5 gives S = 0.83, the 30-degree one 0.97: both far outside.
                EXPECT_NEAR(a[c] / b[c], expected, 1e-4) << "pixel " << x << ", " << y;
            }
        }
    EXPECT_GT(flat, 200);
    EXPECT_GT(tilted, 200);
    EXPECT_LT(minimum, 0.9) << "the tilted texels were reached";
}

TEST_F(PrtSmallScaleGLTest, RendererDirectLightIsUnchangedAndOnlyTheIndirectLightIsOccluded) {
    // The tile with its maps, and a copy whose glTF has neither (same geometry, bin and albedo).
    const auto dir = scratchDir("prt_small_scale_renderer");
    for (const char* name : {"ao_tile.gltf", "ao_tile.bin", "ao_tile_occlusion.png", "ao_tile_normal.png"})
        std::filesystem::copy_file(sourceDir() / kMeshes / name, dir / name);
    std::string text = readText(dir / "ao_tile.gltf");
    for (const std::string key : {"\"occlusionTexture\"", "\"normalTexture\""}) {
        const std::size_t at = text.find(key);
        ASSERT_NE(at, std::string::npos) << key;
        const std::size_t end = text.find('}', at);
        text.erase(text.rfind(',', at), end + 1 - text.rfind(',', at)); // ", "key": {...}"
    }
    std::ofstream(dir / "plain_tile.gltf") << text;
    ASSERT_TRUE(render::loadModel(dir / "plain_tile.gltf").parts[0].material.occlusionTexture.empty()) << text;

    const CameraIntrinsics camera{kSize, kSize, 100.0, 100.0, 63.5, 63.5, {}};
    // Camera 1.2 m above the tile's centre looking down: camera x = world x, y = world -y, z = world -z.
    const Pose world_T_camera(glm::angleAxis(std::numbers::pi, glm::dvec3(1, 0, 0)), {0.5, 0.5, 1.2});
    const std::vector<gi::VirtualAreaLight> vals = testVals();
    const gl::Buffer valBuffer =
        gl::Buffer::create(GLsizeiptr(vals.size() * sizeof(gi::VirtualAreaLight)), vals.data());
    struct Images {
        cv::Mat direct, final, position;
    };
    const auto renderTile = [&](const std::filesystem::path& mesh) {
        render::Scene scene;
        render::SceneObject object;
        object.mesh = mesh;
        object.material.diffuseAlbedo = glm::vec3(0.9f, 0.6f, 0.3f);
        scene.objects.push_back(object);
        render::SceneLight light;
        light.position = {0.3f, 0.6f, 0.9f};
        light.power = glm::vec3(20.0f);
        scene.lights.push_back(light);
        auto renderer = render::Renderer::create(camera);
        renderer->setScene(scene);
        auto prt = gi::MultiscalePrt::create(settings());
        prt->prepare(renderer->instances());
        renderer->renderGBuffer(world_T_camera);
        prt->render({valBuffer.id(), std::uint32_t(vals.size())}, renderer->instances(), renderer->gbuffer(),
                    renderer->viewParameters(), renderer->indirectTarget());
        Images images;
        renderer->shade({true, 0.0f, render::DebugView::DirectOnly, true});
        renderer->readLinearOutputInto(images.direct);
        renderer->shade({true, 0.0f, render::DebugView::Final, true});
        renderer->readLinearOutputInto(images.final);
        gl::Texture position = gl::Texture::wrap(renderer->gbuffer().worldPosition, kSize, kSize);
        gl::readTextureRgba32fInto(position, images.position);
        position.release(); // the renderer owns it
        return images;
    };
    const Images mapped = renderTile(dir / "ao_tile.gltf"), plain = renderTile(dir / "plain_tile.gltf");
    const cv::Mat occlusion = readPng("ao_tile_occlusion.png");
    EXPECT_EQ(cv::countNonZero(mapped.direct.reshape(1) != plain.direct.reshape(1)), 0) << "direct light changed";
    int checked = 0;
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
            const cv::Vec4f p = plain.position.at<cv::Vec4f>(y, x);
            if (p[3] == 0.0f) continue;
            const std::optional<cv::Vec3b> texel = cellTexel(occlusion, p[0], p[1]);
            if (!texel) continue;
            const double ao = 1.0 + 0.75 * ((*texel)[2] / 255.0 - 1.0);
            const cv::Vec4d dm = mapped.direct.at<cv::Vec4f>(y, x), fm = mapped.final.at<cv::Vec4f>(y, x);
            const cv::Vec4d dp = plain.direct.at<cv::Vec4f>(y, x), fp = plain.final.at<cv::Vec4f>(y, x);
            for (int c = 0; c < 3; ++c) {
                const double indirectPlain = fp[c] - dp[c], indirectMapped = fm[c] - dm[c];
                ASSERT_GT(indirectPlain, 1e-3 * dp[c]) << "indirect light at " << x << ", " << y;
                ASSERT_GT(dp[c], 0.0) << "direct light at " << x << ", " << y;
                // final - direct cancels the direct light to float rounding of the sum (~1e-7 of it; the direct
                // light is < 100x the indirect here), so 1e-3 of the indirect light holds; AO on the direct
                // light would move the difference by (1 - ao) x direct, far outside.
                EXPECT_NEAR(indirectMapped, ao * indirectPlain, 1e-3 * indirectPlain + 1e-5 * dp[c])
                    << "pixel " << x << ", " << y;
            }
            ++checked;
        }
    EXPECT_GT(checked, kSize * kSize / 20);
}

TEST_F(PrtSmallScaleGLTest, MapsOnAMeshWithoutTextureCoordinatesAreOff) {
    // Nothing tells where the map lies on such a mesh: S = 1 (with a warning), so the target is the plain one.
    TileRig rig("ao_tile.gltf", false);
    ASSERT_FALSE(rig.instance.material.occlusionTexture.empty());
    const cv::Mat mapped = rig.render(rig.instance.material), plain = rig.render(withoutMaps(rig.instance.material));
    EXPECT_GT(cv::countNonZero(plain.reshape(1) > 0.0f), kSize * kSize / 4) << "the tile is lit";
    EXPECT_EQ(cv::countNonZero(mapped.reshape(1) != plain.reshape(1)), 0);
}

TEST_F(PrtSmallScaleGLTest, MapFileThatIsNoImageIsAnErrorNamingIt) {
    const auto dir = scratchDir("prt_small_scale_bad_map");
    for (const char* name : {"normal_tile.gltf", "ao_tile.bin"})
        std::filesystem::copy_file(sourceDir() / kMeshes / name, dir / name);
    std::ofstream(dir / "ao_tile_normal.png") << "not an image";
    const render::LoadedModel model = render::loadModel(dir / "normal_tile.gltf");
    gi::MeshInstance instance;
    instance.mesh = &model.parts[0].mesh;
    instance.material = model.parts[0].material;
    auto prt = gi::MultiscalePrt::create(settings());
    try {
        prt->prepare({&instance, 1});
        ADD_FAILURE() << "a corrupt normal map was accepted";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("ao_tile_normal.png"), std::string::npos) << error.what();
    }
}

} // namespace
} // namespace lightskin::test
