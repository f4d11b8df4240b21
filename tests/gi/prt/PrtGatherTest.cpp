// Multi-scale PRT's per-frame sparse gather (gi::planPrtGather, the plan overload of prtExitIrradianceInto):
// the VALs' first bounce evaluated at a subset of the exit points and interpolated to the others, against the
// exact per-exit evaluation, with a budget from the interpolation's convexity and the field's Lipschitz
// constant (computed here separately in double precision).
#include "PrtScenes.h"

#include <lightskin/gi/prt/MultiscalePrt.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace lightskin::test {
namespace {

using prt::insideBox;
using prt::PrtScene;
using prt::quadGrid;

// Transfer off (walks end at the entry, which lies on the plane: a plane does not see itself), so the exits
// hold the VALs' first bounce alone.
gi::MultiscalePrtSettings directOnly() {
    gi::MultiscalePrtSettings s;
    s.entryPoints = 4;
    s.walksPerEntry = 1;
    s.maxBounces = 0;
    s.clusters = 1;
    s.basisVectors = 0;
    return s;
}

std::vector<gi::VirtualAreaLight> valsAbovePlane() {
    std::vector<gi::VirtualAreaLight> vals;
    const auto add = [&](glm::vec3 p, glm::vec3 n, float area, glm::vec3 flux) {
        gi::VirtualAreaLight v;
        v.position = p;
        v.normal = glm::normalize(n);
        v.area = area;
        v.flux = flux;
        vals.push_back(v);
    };
    add({0.2f, 0.3f, 0.35f}, {0.1f, 0.0f, -1.0f}, 0.004f, {1.0f, 0.5f, 0.2f});
    add({0.8f, 0.6f, 0.5f}, {-0.3f, 0.2f, -1.0f}, 0.01f, {0.3f, 0.9f, 0.4f});
    add({0.5f, 1.4f, 0.3f}, {0.0f, -1.0f, -0.5f}, 0.002f, {0.6f, 0.6f, 1.2f}); // grazing, off the plane's edge
    return vals;
}

// LightSkin's eq. 3 for a receiver on the plane z = 0 (normal +z), double precision, written out again here:
// E = sum_j phi_j max(0, cos_p) max(0, cos_j) / (pi d^2 + A_j).
glm::dvec3 planeIrradiance(const std::vector<gi::VirtualAreaLight>& vals, glm::dvec2 xy) {
    glm::dvec3 e(0.0);
    for (const gi::VirtualAreaLight& v : vals) {
        const glm::dvec3 d = glm::dvec3(v.position) - glm::dvec3(xy, 0.0);
        const double d2 = glm::dot(d, d), length = std::sqrt(d2);
        const double cosP = std::max(0.0, d.z / length),
                     cosJ = std::max(0.0, -glm::dot(glm::dvec3(v.normal), d) / length);
        e += glm::dvec3(v.flux) * (cosP * cosJ / (std::numbers::pi * d2 + double(v.area)));
    }
    return e;
}

// The interpolated first bounce is a convex combination of the exact values at the gather points an exit
// uses, so |E^(x) - E(x)| <= max_g |E(g) - E(x)| <= L max_g |g - x| on a plane, L the largest gradient
// magnitude of E (per channel) over the plane. L here: central differences on a 401^2 grid over the unit
// square, times 1.1: the gradient changes on the scale of the VALs' heights (>= 0.3 m), so between grid nodes
// 2.5 mm apart it grows by at most ~2.5 mm / 0.3 m < 1 % (the VAL off the edge peaks outside the square).
TEST(PrtGather, PlaneStaysWithinTheLipschitzBoundOfTheExactFirstBounce) {
    PrtScene scene;
    scene.add(quadGrid({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 40), glm::vec3(0.5f));
    const gi::PrtData data = gi::precomputePrt(scene.instances, directOnly());
    const std::size_t X = data.exitCount();
    ASSERT_EQ(X, 41u * 41u);
    const std::vector<gi::VirtualAreaLight> vals = valsAbovePlane();

    glm::dvec3 lipschitz(0.0);
    const int n = 400;
    const double h = 1.0 / n;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const glm::dvec2 p(i * h, j * h);
            const glm::dvec3 gx =
                (planeIrradiance(vals, p + glm::dvec2(h, 0)) - planeIrradiance(vals, p - glm::dvec2(h, 0))) / (2 * h);
            const glm::dvec3 gy =
                (planeIrradiance(vals, p + glm::dvec2(0, h)) - planeIrradiance(vals, p - glm::dvec2(0, h))) / (2 * h);
            lipschitz = glm::max(lipschitz, glm::sqrt(gx * gx + gy * gy));
        }
    lipschitz *= 1.1;

    const std::vector<glm::vec3> noEntries(data.entryCount(), glm::vec3(0.0f));
    std::vector<glm::vec3> exact(X), sparse(X);
    gi::prtExitIrradianceInto(data, vals, noEntries, exact);
    const gi::PrtGatherPlan plan = gi::planPrtGather(data, 128, 4);
    ASSERT_FALSE(plan.exact());
    EXPECT_EQ(plan.points.size(), 128u) << "a plane has no exit without a gather point of its normal nearby";
    std::vector<glm::vec3> gathered(3 * plan.points.size());
    gi::prtExitIrradianceInto(data, plan, vals, noEntries, gathered, sparse);

    double worstRatio = 0.0, sumError2 = 0.0, sumExact2 = 0.0;
    for (std::size_t x = 0; x < X; ++x) {
        double radius = 0.0, weights = 0.0;
        for (std::size_t i = 0; i < 4; ++i) {
            const float w = plan.weight[x * 4 + i];
            ASSERT_GE(w, 0.0f);
            weights += double(w);
            if (w > 0.0f)
                radius = std::max(radius, double(glm::length(data.exitPositions[plan.points[plan.slot[x * 4 + i]]] -
                                                             data.exitPositions[x])));
        }
        ASSERT_NEAR(weights, 1.0, 1e-5) << "exit " << x << ": weights must be a convex combination";
        const glm::dvec3 truth = planeIrradiance(vals, glm::dvec2(data.exitPositions[x]));
        for (int c = 0; c < 3; ++c) {
            // The exact path in float: relative 1e-5 covers its rounding over three VALs.
            ASSERT_NEAR(double(exact[x][c]), truth[c], 1e-5 * truth[c] + 1e-9) << "exit " << x << " channel " << c;
            const double bound = lipschitz[c] * radius + 2e-5 * truth[c] + 1e-9;
            const double error = std::abs(double(sparse[x][c]) - double(exact[x][c]));
            EXPECT_LE(error, bound) << "exit " << x << " channel " << c;
            worstRatio = std::max(worstRatio, error / bound);
            sumError2 += error * error;
            sumExact2 += double(exact[x][c]) * double(exact[x][c]);
        }
    }
    // Not vacuous: the bound is below the values themselves (all-zero output breaks it), and the gather points
    // are fewer than the exits (so interpolation happened).
    double meanBound = 0.0, meanValue = 0.0;
    for (std::size_t x = 0; x < X; ++x) meanValue += double(exact[x].x) / double(X);
    meanBound = lipschitz.x * 0.5 / std::sqrt(128.0); // a gather point per 1/128 of the square: radius ~ 0.04
    EXPECT_LT(meanBound, 0.5 * meanValue);
    EXPECT_GT(sumExact2, 0.0);
    const double relativeRms = std::sqrt(sumError2 / sumExact2);
    EXPECT_GT(relativeRms, 0.0);
    std::printf("relative RMS error of the sparse gather %.3e; worst error / bound %.3f\n", relativeRms, worstRatio);
}

// A UV sphere of radius r around the origin, outward normals.
TriangleMesh uvSphere(float radius, int rings, int segments) {
    TriangleMesh mesh;
    for (int i = 0; i <= rings; ++i)
        for (int j = 0; j <= segments; ++j) {
            const float theta = std::numbers::pi_v<float> * float(i) / float(rings);
            const float phi = 2.0f * std::numbers::pi_v<float> * float(j) / float(segments);
            const glm::vec3 n(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
            mesh.positions.push_back(radius * n);
            mesh.normals.push_back(n);
        }
    const auto at = [&](int i, int j) { return std::uint32_t(i * (segments + 1) + j); };
    for (int i = 0; i < rings; ++i)
        for (int j = 0; j < segments; ++j) {
            mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    return mesh;
}

// Where the normal varies, the gather points' irradiance vectors follow it: a sphere of radius 0.1 m under one
// VAL 10 m away. Over the sphere the vector V (phi cos_j d / (|d| (pi d^2 + A))) changes by at most ~3 r / R =
// 3 % of |V| (1 / d^2 by (1 + r/R)^2 - 1 ~ 2 r / R, the direction by r / R), so |E^(x) - E(x)| <= 0.03 |V| +
// rounding wherever x and its gather points see the VAL alike; near the terminator (n . d ~ 0) some of them do
// not, so exits whose normal is within 30 degrees of it (the neighbour cone) are left out. Interpolating the
// scalar irradiance instead errs by |V| (cos a_x - cos a_g), up to |V| sin 30 degrees / 2 between neighbours.
TEST(PrtGather, IrradianceVectorsFollowTheNormalOnASphere) {
    PrtScene scene;
    scene.add(uvSphere(0.1f, 24, 48), glm::vec3(0.5f));
    const gi::PrtData data = gi::precomputePrt(scene.instances, directOnly());
    const std::size_t X = data.exitCount();
    std::vector<gi::VirtualAreaLight> vals(1);
    vals[0].position = glm::normalize(glm::vec3(1.0f, 0.5f, 0.3f)) * 10.0f;
    vals[0].normal = -glm::normalize(vals[0].position);
    vals[0].area = 0.01f;
    vals[0].flux = {100.0f, 50.0f, 25.0f};
    const std::vector<glm::vec3> noEntries(data.entryCount(), glm::vec3(0.0f));
    std::vector<glm::vec3> exact(X), sparse(X);
    gi::prtExitIrradianceInto(data, vals, noEntries, exact);
    const gi::PrtGatherPlan plan = gi::planPrtGather(data, 64, 4);
    ASSERT_FALSE(plan.exact());
    ASSERT_LT(plan.points.size(), X / 4) << "interpolation must happen";
    std::vector<glm::vec3> gathered(3 * plan.points.size());
    gi::prtExitIrradianceInto(data, plan, vals, noEntries, gathered, sparse);
    const glm::vec3 toLight = glm::normalize(vals[0].position);
    double vectorLength = 0.0; // |V| red: the irradiance of a receiver facing the VAL, from the exact evaluation
    for (std::size_t x = 0; x < X; ++x) vectorLength = std::max(vectorLength, double(exact[x].x));
    ASSERT_GT(vectorLength, 0.0);
    int checked = 0;
    for (std::size_t x = 0; x < X; ++x) {
        if (std::abs(glm::dot(data.exitNormals[x], toLight)) < 0.5f) continue; // within 30 degrees of the terminator
        ++checked;
        EXPECT_NEAR(sparse[x].x, exact[x].x, 0.03 * vectorLength + 1e-6 * vectorLength) << "exit " << x;
    }
    EXPECT_GT(checked, int(X) / 3);
}

// Neighbours never cross an instance or a crease (the box's faces are separate instances and meet at right
// angles), weights are convex, every instance has a gather point, and a plan with at least as many gather
// points as exits is the exact evaluation.
TEST(PrtGather, NeighboursStayOnTheirInstanceAndNormal) {
    const PrtScene box = insideBox(6, glm::vec3(0.5f), true);
    const gi::PrtData data = gi::precomputePrt(box.instances, directOnly());
    const std::size_t X = data.exitCount(), k = 3;
    const auto instanceOf = [&](std::size_t x) {
        std::size_t m = 0;
        while (data.exitOffsets[m + 1] <= x) ++m;
        return m;
    };
    const gi::PrtGatherPlan plan = gi::planPrtGather(data, 24, int(k));
    ASSERT_FALSE(plan.exact());
    EXPECT_GE(plan.points.size(), 24u);
    EXPECT_LT(plan.points.size(), X);
    std::vector<int> pointsPerInstance(box.instances.size(), 0);
    for (const std::uint32_t p : plan.points) ++pointsPerInstance[instanceOf(p)];
    for (const int count : pointsPerInstance) EXPECT_GE(count, 1);
    for (std::size_t x = 0; x < X; ++x) {
        double sum = 0.0;
        for (std::size_t i = 0; i < k; ++i) {
            const float w = plan.weight[x * k + i];
            sum += double(w);
            if (w == 0.0f) continue;
            const std::size_t g = plan.points[plan.slot[x * k + i]];
            EXPECT_EQ(instanceOf(g), instanceOf(x)) << "exit " << x;
            EXPECT_GE(glm::dot(data.exitNormals[g], data.exitNormals[x]), 0.866f) << "exit " << x;
        }
        EXPECT_NEAR(sum, 1.0, 1e-5) << "exit " << x;
    }

    const gi::PrtGatherPlan all = gi::planPrtGather(data, int(X), int(k));
    EXPECT_TRUE(all.exact());
    ASSERT_EQ(all.points.size(), X);
    std::vector<gi::VirtualAreaLight> vals(1);
    vals[0].position = {0.5f, 0.5f, 0.9f};
    vals[0].normal = {0.0f, 0.0f, -1.0f};
    vals[0].area = 0.01f;
    vals[0].flux = {1.0f, 2.0f, 3.0f};
    const std::vector<glm::vec3> noEntries(data.entryCount(), glm::vec3(0.0f));
    std::vector<glm::vec3> exact(X), viaPlan(X), gathered(3 * X);
    gi::prtExitIrradianceInto(data, vals, noEntries, exact);
    gi::prtExitIrradianceInto(data, all, vals, noEntries, gathered, viaPlan);
    double total = 0.0;
    for (std::size_t x = 0; x < X; ++x) {
        for (int c = 0; c < 3; ++c) // n . V against the clamped sum: float rounding only
            EXPECT_NEAR(viaPlan[x][c], exact[x][c], 1e-5f * exact[x][c] + 1e-9f) << "exit " << x;
        total += double(exact[x].x);
    }
    EXPECT_GT(total, 0.0);
}

} // namespace
} // namespace lightskin::test
