// VALs from virtual lights: energy and geometry of reflective-shadow-map VALs against analytic
// expectations (a plane under a spot light and a point light).
#include "GlTestEnvironment.h"
#include "GpuTestMesh.h"
#include "TestMeshes.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/common/ReflectiveShadowMap.h>
#include <lightskin/gi/common/ValSetMerger.h>

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace lightskin::test {
namespace {

using ReflectiveShadowMapGLTest = GlTest;
using gi::VirtualLight;

glm::dvec3 totalFlux(const std::vector<gi::VirtualAreaLight>& vals) {
    glm::dvec3 total(0.0);
    for (const auto& val : vals) total += glm::dvec3(val.flux);
    return total;
}

gi::MeshInstance instanceOf(const GpuTestMesh& gpu, const TriangleMesh& mesh, glm::vec3 albedo, glm::mat4 world_T_model = glm::mat4(1.0f)) {
    gi::MeshInstance instance;
    instance.mesh = &mesh;
    instance.gpu = gpu.view;
    instance.world_T_model = world_T_model;
    instance.material.diffuseAlbedo = albedo;
    return instance;
}

// A spot light whose whole cone lands on a plane: the VAL fluxes sum to albedo * power
// (power = I 2 pi (1 - cos beta)), and the true-area variant sums to the lit disc's area.
TEST_F(ReflectiveShadowMapGLTest, SpotOnAPlaneReflectsAlbedoTimesPower) {
    const TriangleMesh plane = planeGrid(6.0f, 4);
    const GpuTestMesh gpu = GpuTestMesh::upload(plane);
    const glm::vec3 albedo(0.8f, 0.5f, 0.2f);
    const gi::MeshInstance instances[] = {instanceOf(gpu, plane, albedo)};
    VirtualLight spot;
    spot.position = {0.1f, -0.2f, 1.5f};
    spot.direction = {0.0f, 0.0f, -1.0f};
    spot.spotHalfAngle = 0.5f;
    spot.intensity = {2.0f, 3.0f, 4.0f};
    for (bool paperArea : {true, false}) {
        gi::RsmSettings settings;
        settings.resolution = 256;
        settings.areaFacingLight = paperArea;
        gi::ReflectiveShadowMap rsm = gi::ReflectiveShadowMap::create(settings);
        const gi::ValSetView set = rsm.generate(std::span(&spot, 1), instances);
        const auto vals = rsm.downloadVals();
        ASSERT_EQ(set.count, vals.size());
        ASSERT_GT(vals.size(), 40000u); // pi/4 of 256^2 texels lie in the cone
        const glm::dvec3 expected = glm::dvec3(albedo) * gi::radiantPower(spot);
        const glm::dvec3 flux = totalFlux(vals);
        // The cone's rim cuts texels: the texel-centre test mis-assigns half a texel ring on average,
        // ~ perimeter / area = 2 / (128 px radius) * (1/2 px) -> a few 1e-3.
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(flux[c] / expected[c], 1.0, 5e-3) << c;
        double area = 0.0;
        for (const auto& val : vals) {
            EXPECT_NEAR(val.position.z, 0.0f, 1e-5f);
            EXPECT_NEAR(val.normal.z, 1.0f, 1e-5f);
            area += double(val.area);
        }
        const double litRadius = 1.5 * std::tan(0.5);
        if (!paperArea) {
            EXPECT_NEAR(area / (std::numbers::pi * litRadius * litRadius), 1.0, 5e-3);
        } else {
            // Paper area d^2 omega: each patch as if it faced the light, smaller by cos(theta_l).
            EXPECT_LT(area, std::numbers::pi * litRadius * litRadius);
            EXPECT_GT(area, std::cos(0.5) * std::numbers::pi * litRadius * litRadius);
        }
    }
}

// A point light above a square receives the square's solid angle, 4 asin(a b / sqrt((a^2+h^2)(b^2+h^2))).
TEST_F(ReflectiveShadowMapGLTest, PointLightAboveASquareReflectsItsSolidAngle) {
    const TriangleMesh plane = planeGrid(2.0f, 2);
    const GpuTestMesh gpu = GpuTestMesh::upload(plane);
    const gi::MeshInstance instances[] = {instanceOf(gpu, plane, glm::vec3(0.5f))};
    VirtualLight point;
    point.type = VirtualLight::Type::Point;
    point.position = {0.0f, 0.0f, 0.7f};
    point.intensity = glm::vec3(1.0f);
    gi::RsmSettings settings;
    settings.resolution = 256;
    gi::ReflectiveShadowMap rsm = gi::ReflectiveShadowMap::create(settings);
    rsm.generate(std::span(&point, 1), instances);
    const auto vals = rsm.downloadVals();
    const double a = 1.0, h = 0.7;
    const double solidAngle = 4.0 * std::asin(a * a / ((a * a + h * h)));
    // Square edges cut texels as the cone rim does above; the cube-face seams are exact.
    EXPECT_NEAR(totalFlux(vals).x / (0.5 * solidAngle), 1.0, 5e-3);
}

// Millimetre to kilometre scenes: the automatic light frustum keeps the energy balance exact.
TEST_F(ReflectiveShadowMapGLTest, EnergyIsScaleFree) {
    const TriangleMesh plane = planeGrid(6.0f, 4);
    const GpuTestMesh gpu = GpuTestMesh::upload(plane);
    for (float scale : {1e-3f, 1e3f}) {
        const gi::MeshInstance instances[] = {
            instanceOf(gpu, plane, glm::vec3(0.5f), glm::scale(glm::mat4(1.0f), glm::vec3(scale)))};
        VirtualLight spot;
        spot.position = glm::vec3(0.0f, 0.0f, 1.5f * scale);
        spot.spotHalfAngle = 0.5f;
        gi::RsmSettings settings;
        settings.resolution = 128;
        gi::ReflectiveShadowMap rsm = gi::ReflectiveShadowMap::create(settings);
        rsm.generate(std::span(&spot, 1), instances);
        const auto vals = rsm.downloadVals();
        EXPECT_NEAR(totalFlux(vals).x / (0.5 * gi::radiantPower(spot).x), 1.0, 1e-2) << scale;
        double area = 0.0;
        for (const auto& val : vals) area += double(val.area);
        const double litRadius = 1.5 * double(scale) * std::tan(0.5);
        EXPECT_GT(area, std::cos(0.5) * std::numbers::pi * litRadius * litRadius * 0.99) << scale;
        EXPECT_LT(area, std::numbers::pi * litRadius * litRadius) << scale;
    }
}

// Two lights and an occluder: each light contributes separately; a blocked region reflects nothing.
TEST_F(ReflectiveShadowMapGLTest, SeveralLightsAddAndTheNearestSurfaceTakesTheLight) {
    const TriangleMesh floor = planeGrid(10.0f, 4);
    const TriangleMesh blocker = planeGrid(0.4f, 1);
    const GpuTestMesh floorGpu = GpuTestMesh::upload(floor), blockerGpu = GpuTestMesh::upload(blocker);
    const gi::MeshInstance instances[] = {
        instanceOf(floorGpu, floor, glm::vec3(1.0f)),
        instanceOf(blockerGpu, blocker, glm::vec3(0.0f), glm::translate(glm::mat4(1.0f), glm::vec3(0, 0, 0.5f)))};
    VirtualLight lights[2];
    lights[0].position = {0, 0, 1};
    lights[0].spotHalfAngle = 0.6f;
    lights[1] = lights[0];
    lights[1].position = {3, 0, 1};
    gi::RsmSettings settings;
    settings.resolution = 128;
    gi::ReflectiveShadowMap rsm = gi::ReflectiveShadowMap::create(settings);
    rsm.generate(lights, instances);
    const auto vals = rsm.downloadVals();
    // The black blocker (half side 0.2 at height 0.5 below light 0) eats the solid angle of a
    // 0.4 x 0.4 square at distance 0.5: 4 asin(0.04 / 0.29).
    const double blocked = 4.0 * std::asin(0.2 * 0.2 / (0.2 * 0.2 + 0.5 * 0.5));
    const double expected = 2.0 * gi::radiantPower(lights[0]).x - blocked;
    EXPECT_NEAR(totalFlux(vals).x / expected, 1.0, 1e-2);
    for (const auto& val : vals) {
        EXPECT_TRUE(val.flux.x >= 0.0f && std::isfinite(val.flux.x));
        if (val.position.z > 0.25f) {
            EXPECT_EQ(val.flux.x, 0.0f); // blocker VALs carry albedo 0
        }
    }
    gi::ReflectiveShadowMap small = gi::ReflectiveShadowMap::create({.resolution = 8, .maxLights = 1});
    EXPECT_THROW(small.generate(lights, instances), Error);
}

// RSM VALs and any other set merge back to back into one packed set.
TEST_F(ReflectiveShadowMapGLTest, SetsMergeInOrderAndOverflowIsCounted) {
    const TriangleMesh plane = planeGrid(6.0f, 4);
    const GpuTestMesh gpu = GpuTestMesh::upload(plane);
    const gi::MeshInstance instances[] = {instanceOf(gpu, plane, glm::vec3(0.5f))};
    VirtualLight spot;
    spot.position = {0, 0, 1};
    gi::ReflectiveShadowMap rsm = gi::ReflectiveShadowMap::create({.resolution = 16, .maxLights = 1});
    const gi::ValSetView first = rsm.generate(std::span(&spot, 1), instances);
    const auto firstVals = rsm.downloadVals();
    std::vector<gi::VirtualAreaLight> other(5);
    for (std::size_t i = 0; i < other.size(); ++i) other[i].area = float(i + 1);
    gl::Buffer otherBuffer = gl::Buffer::create(GLsizeiptr(other.size() * sizeof(gi::VirtualAreaLight)), other.data());
    const gi::ValSetView sets[] = {first, {otherBuffer.id(), 5}, {0, 0}};
    gi::ValSetMerger merger = gi::ValSetMerger::create(first.count + 5);
    const gi::ValSetView merged = merger.merge(sets);
    ASSERT_EQ(merged.count, first.count + 5);
    EXPECT_EQ(merger.lastDropped(), 0u);
    std::vector<gi::VirtualAreaLight> out(merged.count);
    glGetNamedBufferSubData(merged.buffer, 0, GLsizeiptr(out.size() * sizeof(gi::VirtualAreaLight)), out.data());
    for (std::size_t i = 0; i < firstVals.size(); ++i) EXPECT_EQ(out[i].position, firstVals[i].position);
    for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ(out[first.count + i].area, float(i + 1));
    gi::ValSetMerger small = gi::ValSetMerger::create(first.count + 2);
    EXPECT_EQ(small.merge(sets).count, first.count + 2);
    EXPECT_EQ(small.lastDropped(), 3u);
}

} // namespace
} // namespace lightskin::test
