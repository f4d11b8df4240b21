// Adaptive mode, VAL culling (LightSkinSettings::adaptive, gi/lightskin/shaders/gather_cull.glsl): the
// culled list is the stable filter of the input, i.e. equal bit for bit to a CPU filter of the same
// VALs with the same predicate, in input order, for counts around the work-group (256) and scan-run
// boundaries (256 groups = 65536 VALs), with invalid (NaN, zero, negative area) VALs; and two fresh
// adaptive techniques give bit-identical gather sums, vertex VPLs and images.
//
// The CPU predicate is evaluated in double; VALs whose plane test or irradiance bound lies within
// 1e-3 (relative) of the decision are moved away from it, so float and double agree on every
// decision by construction and the comparison tests the order and completeness of the compaction.
#include "CarriesTheLight.h"
#include "common/GatherTestScenes.h"
#include "GlTestEnvironment.h"
#include "common/GpuRig.h"

#include <lightskin/gi/lightskin/LightSkinIllumination.h>
#include <lightskin/gi/common/SimpleGBuffer.h>
#include <lightskin/gi/common/VertexSparsePoints.h>
#include <lightskin/gl/Objects.h>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>
#include <random>

namespace lightskin::test {
namespace {

/// The shared rig at 48 x 48 pixels, rendering with explicit VALs.
struct Scene : GpuRig {
    Scene() { width = height = 48; }
    void render(gi::LightSkinIllumination& technique, const gi::ValSetView& vals) {
        const gi::ViewParameters v = view();
        gbuffer.render(instances, v.clip_T_world);
        technique.render(vals, instances, gbuffer.view(), v, output.id());
    }
    std::vector<glm::vec4> image() const {
        std::vector<glm::vec4> out(std::size_t(width) * std::size_t(height));
        glGetTextureImage(output.id(), 0, GL_RGBA, GL_FLOAT, GLsizei(out.size() * sizeof(glm::vec4)), out.data());
        return out;
    }
};

gl::Buffer upload(const std::vector<gi::VirtualAreaLight>& vals) {
    return gl::Buffer::create(GLsizeiptr(std::max<std::size_t>(vals.size(), 1) * sizeof(gi::VirtualAreaLight)),
                              vals.empty() ? nullptr : vals.data(), GL_DYNAMIC_STORAGE_BIT);
}

gi::LightSkinSettings adaptive(float cutoff) {
    gi::LightSkinSettings s;
    s.adaptive = true;
    s.reuseStatic = false;
    s.glossy = false;
    s.occlusion = false;
    s.valInfluenceCutoff = cutoff;
    s.valCapacity = 1024; // the larger sets grow the buffers (the growth path is part of the test)
    return s;
}

/// The receivers' bounding sphere as the technique computes it (bounding box of the sparse points).
glm::vec4 receiverSphere(const gi::LightSkinIllumination& technique, const Scene& scene) {
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (std::size_t m = 0; m < technique.sparsePoints().size(); ++m)
        for (const gi::SparsePoint& p : technique.sparsePoints()[m].points) {
            const glm::vec3 w(scene.instances[m].world_T_model * glm::vec4(p.position, 1.0f));
            lo = glm::min(lo, w);
            hi = glm::max(hi, w);
        }
    const glm::vec3 centre = 0.5f * (lo + hi);
    return glm::vec4(centre, glm::length(hi - centre) * 1.0001f + 1e-6f);
}

/// The cull predicate in double (gather_cull.glsl): signed margin to the plane test and the
/// irradiance bound; the VAL is kept if area > 0, plane >= 0 and bound >= cutoff.
struct Decision {
    bool valid = false;
    double plane = 0.0, bound = 0.0;
};
Decision decide(const gi::VirtualAreaLight& val, const glm::vec4& sphere) {
    Decision d;
    d.valid = val.area > 0.0f;
    const glm::dvec3 toCentre = glm::dvec3(glm::vec3(sphere)) - glm::dvec3(val.position);
    d.plane = glm::dot(glm::dvec3(val.normal), toCentre) + double(sphere.w);
    const double dMin = std::max(glm::length(toCentre) - double(sphere.w), 0.0);
    const double r2 = double(val.area) / 3.14159265;
    d.bound = double(std::max({val.flux.r, val.flux.g, val.flux.b})) / (3.14159265 * (r2 + dMin * dMin));
    return d;
}
bool keeps(const Decision& d, double cutoff) { return d.valid && d.plane >= 0.0 && d.bound >= cutoff; }

/// `count` random VALs around the receivers: every 17th NaN area, every 23rd zero, every 29th
/// negative; random normals (about half face away); none within 1e-3 of a decision.
std::vector<gi::VirtualAreaLight> randomSet(std::size_t count, const glm::vec4& sphere, float cutoff,
                                            std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<gi::VirtualAreaLight> vals(count);
    for (std::size_t i = 0; i < count; ++i) {
        gi::VirtualAreaLight& v = vals[i];
        for (;;) {
            v.position =
                glm::vec3(-2.0f, -2.0f, -1.0f) + glm::vec3(4.0f, 4.0f, 3.0f) * glm::vec3(u(rng), u(rng), u(rng));
            const float z = 2.0f * u(rng) - 1.0f, phi = 2.0f * std::numbers::pi_v<float> * u(rng);
            const float s = std::sqrt(std::max(1.0f - z * z, 0.0f));
            v.normal = {s * std::cos(phi), s * std::sin(phi), z};
            v.area = 1e-3f + 1e-2f * u(rng);
            v.flux = glm::vec3(u(rng), u(rng), u(rng)) * 0.2f;
            const Decision d = decide(v, sphere);
            if (std::abs(d.plane) > 1e-3 * double(sphere.w) &&
                (cutoff == 0.0f || std::abs(d.bound / double(cutoff) - 1.0) > 1e-3))
                break;
        }
        if (i % 17 == 5) v.area = std::numeric_limits<float>::quiet_NaN();
        if (i % 23 == 7) v.area = 0.0f;
        if (i % 29 == 11) v.area = -v.area;
    }
    return vals;
}

bool sameBytes(const gi::VirtualAreaLight& a, const gi::VirtualAreaLight& b) {
    return std::memcmp(&a, &b, sizeof a) == 0;
}

template <class T>
bool bitIdentical(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

Scene floorScene() {
    Scene scene;
    Material floor;
    floor.diffuseAlbedo = {0.5f, 0.5f, 0.5f};
    scene.add(makeGrid(1.0f, 4), glm::mat4(1.0f), floor, 16);
    scene.upload();
    return scene;
}

using LightSkinCullGLTest = GlTest;

TEST_F(LightSkinCullGLTest, CulledListIsTheStableFilterOfTheInputBitForBit) {
    Scene scene = floorScene();
    for (const float cutoff : {0.0f, 0.05f}) {
        auto technique = scene.technique(adaptive(cutoff));
        const glm::vec4 sphere = receiverSphere(*technique, scene);
        ASSERT_GT(sphere.w, 0.5f); // the 1 m floor grid
        std::uint32_t seed = 1;
        for (const std::size_t count : {0u, 1u, 63u, 64u, 65u, 255u, 256u, 257u, 65535u, 65536u, 65537u, 300000u}) {
            const auto vals = randomSet(count, sphere, cutoff, seed++);
            std::vector<gi::VirtualAreaLight> expected;
            std::size_t invalid = 0, behind = 0, weak = 0;
            for (const gi::VirtualAreaLight& v : vals) {
                const Decision d = decide(v, sphere);
                if (keeps(d, double(cutoff))) expected.push_back(v);
                invalid += !d.valid;
                behind += d.valid && d.plane < 0.0;
                weak += d.valid && d.plane >= 0.0 && d.bound < double(cutoff);
            }
            if (count >= 1000) { // every reason to drop a VAL occurs
                EXPECT_GT(invalid, count / 10);
                EXPECT_GT(behind, count / 10);
                if (cutoff > 0.0f) {
                    EXPECT_GT(weak, count / 100);
                }
                EXPECT_GT(expected.size(), count / 10);
            }
            const gl::Buffer buffer = upload(vals);
            scene.render(*technique, {buffer.id(), std::uint32_t(count)});
            std::vector<gi::VirtualAreaLight> culled;
            technique->readGatheredVals(culled);
            EXPECT_EQ(technique->lastChoice().valsGathered, expected.size()) << count << " VALs, cutoff " << cutoff;
            ASSERT_EQ(culled.size(), expected.size()) << count << " VALs, cutoff " << cutoff;
            std::size_t firstDifference = culled.size();
            for (std::size_t i = 0; i < culled.size() && firstDifference == culled.size(); ++i)
                if (!sameBytes(culled[i], expected[i])) firstDifference = i;
            EXPECT_EQ(firstDifference, culled.size()) << count << " VALs, cutoff " << cutoff << ": lists differ";
        }
    }
}

TEST_F(LightSkinCullGLTest, UnorderedMeasurementVariantKeepsTheSameVals) {
    // stableCull = false (the former atomic append, kept for measurement): same set, any order
    Scene scene = floorScene();
    auto stable = scene.technique(adaptive(0.05f));
    gi::LightSkinSettings settings = adaptive(0.05f);
    settings.stableCull = false;
    auto unordered = scene.technique(settings);
    const auto vals = randomSet(20000, receiverSphere(*stable, scene), 0.05f, 99);
    const gl::Buffer buffer = upload(vals);
    std::vector<gi::VirtualAreaLight> a, b;
    scene.render(*stable, {buffer.id(), std::uint32_t(vals.size())});
    stable->readGatheredVals(a);
    scene.render(*unordered, {buffer.id(), std::uint32_t(vals.size())});
    unordered->readGatheredVals(b);
    ASSERT_GT(a.size(), 1000u);
    const auto byBytes = [](const gi::VirtualAreaLight& x, const gi::VirtualAreaLight& y) {
        return std::memcmp(&x, &y, sizeof x) < 0;
    };
    std::sort(a.begin(), a.end(), byBytes);
    std::sort(b.begin(), b.end(), byBytes);
    EXPECT_TRUE(bitIdentical(a, b));
}

TEST_F(LightSkinCullGLTest, TwoFreshAdaptiveTechniquesGiveBitIdenticalResults) {
    Scene scene;
    Material sphere;
    sphere.diffuseAlbedo = {0.8f, 0.7f, 0.6f};
    sphere.specularAlbedo = glm::vec3(0.3f);
    sphere.specularExponent = 20.0f;
    scene.add(makeSphere(0.3f, 12, 24), glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 0.45f}), sphere, 120);
    Material floor;
    floor.diffuseAlbedo = {0.5f, 0.5f, 0.5f};
    floor.specularAlbedo = glm::vec3(0.2f);
    floor.specularExponent = 5.0f;
    scene.add(makeGrid(2.0f, 12), glm::mat4(1.0f), floor, 60);
    scene.upload();
    // a wall emitter and many random VALs (above and below the floor: about half culled), so the
    // kept VALs span many cull work groups and gather passes (on llvmpipe an atomic append's order
    // varies between runs only when work groups of several threads interleave: large sets)
    auto vals = squareEmitter({-1.0f, 0.0f, 0.6f}, {1.0f, 0.0f, 0.0f}, 1.2f, 24, {1.0f, 0.8f, 0.6f});
    for (const float z : {1.5f, -2.0f}) { // below: facing down, the receivers' sphere behind them
        const auto extra = randomVals(150000, {-1.5f, -1.5f, z - 0.5f}, {1.5f, 1.5f, z + 0.5f}, {0, 0, 100.0f * z},
                                      0.005f, z > 0.0f ? 11u : 12u);
        vals.insert(vals.end(), extra.begin(), extra.end());
    }
    const gl::Buffer buffer = upload(vals);
    const gi::ValSetView set{buffer.id(), std::uint32_t(vals.size())};
    gi::LightSkinSettings settings;
    settings.adaptive = true;
    settings.reuseStatic = false;
    struct Result {
        std::vector<glm::vec4> image, gather, vertex;
        std::vector<gi::VirtualAreaLight> vals;
        gi::LightSkinChoice choice;
    };
    const auto run = [&] {
        auto technique = scene.technique(settings);
        scene.render(*technique, set);
        Result r;
        r.image = scene.image();
        technique->readGatherSums(r.gather);
        technique->readVertexVpls(r.vertex);
        r.choice = technique->lastChoice();
        technique->readGatheredVals(r.vals);
        return r;
    };
    const Result a = run(), b = run();
    ASSERT_TRUE(a.choice.glossy && a.choice.occlusion);
    EXPECT_LT(a.choice.valsGathered, a.choice.valsIn * 3 / 4); // the cull dropped the VALs below the floor
    EXPECT_GT(a.choice.valsGathered, a.choice.valsIn / 3);
    // two all-zero images would be identical too: the culled run must carry the light of all VALs
    // (the dropped ones face away or lie below the cutoff); every 20th pixel keeps the double brute
    // force over 300k VALs at ~1 s
    expectCarriesTheLight(scene, a.image, vals, true, "culled, glossy + occlusion", 20);
    EXPECT_TRUE(bitIdentical(a.vals, b.vals)); // the former atomic append failed here in 1 of 3 runs
    EXPECT_TRUE(bitIdentical(a.gather, b.gather));
    EXPECT_TRUE(bitIdentical(a.vertex, b.vertex));
    EXPECT_TRUE(bitIdentical(a.image, b.image));
}

} // namespace
} // namespace lightskin::test
