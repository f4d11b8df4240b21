// Multi-scale PRT's entry-point weighting (sec. 7.1, MultiscalePrtSettings::entryLightPoints/entryLightFraction):
// the weighted transfer divides by its density, so it agrees with the uniform one in expectation (replicas'
// standard errors), and where the light comes from one side it has a lower variance (= error, both being
// unbiased) at the same entry count.
#include "PrtScenes.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/prt/MultiscalePrt.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <tuple>
#include <vector>

namespace lightskin::test {
namespace {

using prt::insideBox;
using prt::PrtScene;

// The box open at the top, lit by a directional light from the upper -x side at 45 degrees, L = (-1, 0, 1) /
// sqrt(2): the x = 0 wall (height 1) shadows the whole floor (a floor point at x < 1 sees the wall top at
// elevation > 45 degrees), the x = 0 and y walls face away or edge-on, so only the x = 1 wall (normal -x) is
// lit, with E = n . L = 1 / sqrt(2). Unit irradiance per unit n . L; no Embree needed for this truth.
glm::vec3 oneSidedIrradiance(const glm::vec3& /*position*/, const glm::vec3& normal) {
    return normal.x < -0.5f ? glm::vec3(float(1.0 / std::sqrt(2.0))) : glm::vec3(0.0f);
}

glm::vec3 uniformIrradiance(const glm::vec3&, const glm::vec3&) { return glm::vec3(1.0f); }

using Lighting = std::function<glm::vec3(const glm::vec3&, const glm::vec3&)>;

// S = sum over exits of sum_e I(x_e) T_e[x] (red channel; the albedo is grey), the uncompressed transfer.
double totalTransfer(const gi::PrtData& data, const Lighting& lighting) {
    const std::size_t X = data.exitCount();
    double sum = 0.0;
    for (std::size_t e = 0; e < data.entryCount(); ++e) {
        const double irradiance = double(lighting(data.entryPositions[e], data.entryNormals[e]).x);
        if (irradiance == 0.0) continue;
        for (std::size_t x = 0; x < X; ++x) sum += irradiance * double(data.uncompressed[e * 3 * X + x]);
    }
    return sum;
}

struct Sample {
    double mean = 0.0, variance = 0.0; ///< over the replicas (unbiased variance)
    double standardError() const { return std::sqrt(variance / kReplicas); }
    static constexpr double kReplicas = 24.0;
};

struct Replicas {
    Sample oneSided, uniform;
};

Replicas replicate(const PrtScene& scene, gi::MultiscalePrtSettings settings) {
    std::vector<double> a, b;
    for (int r = 0; r < int(Sample::kReplicas); ++r) {
        settings.seed = std::uint32_t(500 + r);
        const gi::PrtData data = gi::precomputePrt(scene.instances, settings);
        a.push_back(totalTransfer(data, oneSidedIrradiance));
        b.push_back(totalTransfer(data, uniformIrradiance));
    }
    const auto stats = [](const std::vector<double>& v) {
        Sample s;
        for (double x : v) s.mean += x / double(v.size());
        for (double x : v) s.variance += (x - s.mean) * (x - s.mean) / double(v.size() - 1);
        return s;
    };
    return {stats(a), stats(b)};
}

gi::MultiscalePrtSettings settings() {
    gi::MultiscalePrtSettings s;
    s.entryPoints = 32; // few entries: their placement, not the walks, dominates the variance
    s.walksPerEntry = 8;
    s.maxBounces = 4;
    s.clusters = 1;
    s.basisVectors = 0;
    s.keepUncompressed = true;
    return s;
}

// One test point 20 m away along L: cos / d^2 is nearly constant over the lit wall and Embree's visibility
// through the open top leaves the floor and the other walls to the uniform part.
gi::MultiscalePrtSettings weightedTowardTheLight(gi::MultiscalePrtSettings s, float fraction) {
    s.entryLightPoints = {glm::vec3(0.5f) + 20.0f * glm::normalize(glm::vec3(-1.0f, 0.0f, 1.0f))};
    s.entryLightFraction = fraction;
    return s;
}

void print(const char* what, const Replicas& uniform, const Replicas& weighted) {
    std::printf("%s: one-sided light: uniform %.5f +- %.5f, weighted %.5f +- %.5f; uniform light: uniform %.5f +- "
                "%.5f, weighted %.5f +- %.5f\n",
                what, uniform.oneSided.mean, uniform.oneSided.standardError(), weighted.oneSided.mean,
                weighted.oneSided.standardError(), uniform.uniform.mean, uniform.uniform.standardError(),
                weighted.uniform.mean, weighted.uniform.standardError());
}

// Unbiased both: the difference of the means within 4 combined standard errors (Welch, ~40 degrees of freedom:
// a false failure has probability ~3e-4 per comparison), under the light the weighting expects and under
// uniform light, where half the weighted entries crowd onto one wall of five and only the 1 / p correction
// keeps the mean; the combined standard error must stay below 7 % of the mean, so a 30 % bias is caught (a
// missing correction triples the one-sided mean: 0.5 + 0.5 / 5 of the entries land on the lit wall, not 1/5).
TEST(PrtEntryWeighting, AgreesWithTheUniformTransferInExpectation) {
    const PrtScene box = insideBox(4, glm::vec3(0.6f), false);
    gi::MultiscalePrtSettings s = settings();
    s.entryPoints = 48;
    s.walksPerEntry = 4;
    const Replicas uniform = replicate(box, s);
    const Replicas weighted = replicate(box, weightedTowardTheLight(s, 0.5f));
    print("f = 0.5, 48 entries", uniform, weighted);
    for (const auto& [a, b, what] : {std::tuple{uniform.oneSided, weighted.oneSided, "one-sided light"},
                                     std::tuple{uniform.uniform, weighted.uniform, "uniform light"}}) {
        const double combined = std::sqrt(a.variance / Sample::kReplicas + b.variance / Sample::kReplicas);
        EXPECT_GT(combined, 0.0) << what;
        EXPECT_LT(combined, 0.07 * a.mean) << what << ": too noisy to detect a 30 % bias";
        EXPECT_NEAR(b.mean, a.mean, 4.0 * combined) << what;
    }
}

// A lower error at equal entry count under the light it was weighted for: uniform puts ~1/5 of the entries on
// the lit wall, the weighted 0.9 + 0.1 / 5 = 0.92, so its variance should be ~4.6 times smaller at least (more:
// the uniform count on the wall varies too); both are unbiased, so variance = mean squared error. With 24
// replicas each the observed ratio is F(23, 23) distributed around that: observing a reduction below 1.5 has
// probability < 1 % (F(23, 23) < 1.5 / 4.6 = 0.33).
TEST(PrtEntryWeighting, HasALowerErrorUnderTheLightItWasWeightedFor) {
    const PrtScene box = insideBox(4, glm::vec3(0.6f), false);
    const Replicas uniform = replicate(box, settings());
    const Replicas weighted = replicate(box, weightedTowardTheLight(settings(), 0.9f));
    print("f = 0.9, 32 entries", uniform, weighted);
    EXPECT_GT(weighted.oneSided.mean, 0.0);
    EXPECT_GT(uniform.oneSided.variance, 0.0);
    EXPECT_LT(1.5 * weighted.oneSided.variance, uniform.oneSided.variance);
    std::printf("variance ratio uniform / weighted under one-sided light: %.2f\n",
                uniform.oneSided.variance / weighted.oneSided.variance);
}

TEST(PrtEntryWeighting, UniformSettingsKeepTheirCacheKeyAndWeightsChangeIt) {
    const PrtScene box = insideBox(2, glm::vec3(0.6f), false);
    gi::MultiscalePrtSettings s = settings();
    const std::uint64_t uniform = gi::prtCacheKey(box.instances, s);
    s.entryLightPoints = {glm::vec3(0.5f, 0.5f, 3.0f)};
    EXPECT_EQ(gi::prtCacheKey(box.instances, s), uniform) << "fraction 0: still uniform";
    s.entryLightFraction = 0.5f;
    EXPECT_NE(gi::prtCacheKey(box.instances, s), uniform);
    s.entryLightFraction = 1.0f;
    EXPECT_THROW(gi::validate(s), Error);
}

} // namespace
} // namespace lightskin::test
