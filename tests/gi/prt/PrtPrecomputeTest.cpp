// Multi-scale PRT's precompute (gi/prt/src/PrtPrecompute.cpp) against closed forms and separately written
// quadrature: the furnace (a closed box of uniform albedo), energy conservation in an open box, the clustered
// PCA's reconstruction error against the uncompressed transfer (Eckart-Young), spectral obscurances of a plane
// and of a concave corner.
#include "PrtScenes.h"

#include <lightskin/gi/prt/MultiscalePrt.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

namespace lightskin::test {
namespace {

using prt::insideBox;
using prt::PrtScene;
using prt::quadGrid;

// Exit points of the unit box at least 0.25 from their face's border: no walk vertex on another face comes
// closer than 0.25, so the connection kernel cos cos / (pi d^2) stays below 1 / (pi 0.0625) and the Monte Carlo
// estimate has a bounded variance (near edges it does not: 1 / d^2 is not square-integrable there).
bool interiorOfBoxFace(const glm::vec3& p) {
    int near = 0;
    for (int k = 0; k < 3; ++k) near += std::min(p[k], 1.0f - p[k]) < 0.25f - 1e-5f ? 1 : 0;
    return near == 1;
}

// S[x] = sum_e T_e[x] of the uncompressed transfer, channel c: the irradiance at x when every point of the
// virtual surfaces receives unit irradiance.
std::vector<glm::dvec3> unitIrradianceTransfer(const gi::PrtData& data) {
    const std::size_t X = data.exitCount();
    std::vector<glm::dvec3> sum(X, glm::dvec3(0.0));
    for (std::size_t e = 0; e < data.entryCount(); ++e)
        for (std::size_t c = 0; c < 3; ++c)
            for (std::size_t x = 0; x < X; ++x) sum[x][int(c)] += double(data.uncompressed[(e * 3 + c) * X + x]);
    return sum;
}

struct Replicas {
    glm::dvec3 mean{0.0}, standardError{0.0};
};

// Mean and standard error over `count` independent seeds of the average of S over the selected exit points.
template <class Select>
Replicas replicateAverage(const PrtScene& scene, gi::MultiscalePrtSettings settings, int count, Select select) {
    std::vector<glm::dvec3> values;
    for (int r = 0; r < count; ++r) {
        settings.seed = std::uint32_t(1000 + r);
        const gi::PrtData data = gi::precomputePrt(scene.instances, settings);
        const std::vector<glm::dvec3> s = unitIrradianceTransfer(data);
        glm::dvec3 average(0.0);
        int n = 0;
        for (std::size_t x = 0; x < data.exitCount(); ++x)
            if (select(data.exitPositions[x])) average += s[x], ++n;
        EXPECT_GT(n, 0);
        values.push_back(average / double(std::max(n, 1)));
    }
    Replicas out;
    for (const glm::dvec3& v : values) out.mean += v / double(count);
    glm::dvec3 variance(0.0);
    for (const glm::dvec3& v : values) variance += (v - out.mean) * (v - out.mean) / double(count - 1);
    out.standardError = glm::sqrt(variance / double(count));
    return out;
}

gi::MultiscalePrtSettings transferSettings() {
    gi::MultiscalePrtSettings s;
    s.entryPoints = 192;
    s.walksPerEntry = 8;
    s.maxBounces = 64; // survival <= 0.7 per bounce: a walk of more than 64 has probability 0.7^64 < 1e-9
    s.clusters = 4;
    s.basisVectors = 2;
    s.minConnectionDistance = 0.0f; // the interior exit points are >= 0.25 from every other face
    s.keepUncompressed = true;
    return s;
}

// A closed box of albedo rho under unit irradiance everywhere: every surface has radiosity B with
// B = rho (1 + B) in the steady state, so the irradiance from the other surfaces is rho / (1 - rho)
// (the geometric series rho + rho^2 + ...), for each channel separately.
TEST(PrtFurnace, ClosedBoxGivesTheGeometricSeries) {
    const glm::vec3 rho(0.3f, 0.5f, 0.7f);
    const PrtScene box = insideBox(4, rho, true);
    // 8 replicas: |mean - truth| <= 5 standard errors fails with probability 0.0016 per channel (t, 7 dof)
    // for an unbiased estimator; a bias of 1 % (e.g. a lost bounce in 100) exceeds it (standard error ~0.1 %).
    const Replicas r = replicateAverage(box, transferSettings(), 8, interiorOfBoxFace);
    for (int c = 0; c < 3; ++c) {
        const double expected = double(rho[c]) / (1.0 - double(rho[c]));
        EXPECT_NEAR(r.mean[c], expected, 5.0 * r.standardError[c]) << "channel " << c;
        EXPECT_GT(r.standardError[c], 0.0);
        EXPECT_LT(r.standardError[c], 0.02 * expected) << "too noisy to detect a 10 % error";
    }
}

// Energy conservation: with an open top, part of the light leaves, so the unit-irradiance transfer stays
// below the closed box's rho / (1 - rho) at every interior exit point, by more than its noise.
TEST(PrtFurnace, OpenBoxStaysBelowTheGeometricSeries) {
    const glm::vec3 rho(0.6f);
    const PrtScene box = insideBox(4, rho, false);
    gi::MultiscalePrtSettings settings = transferSettings();
    const double bound = 0.6 / (1.0 - 0.6);
    const gi::PrtData data = gi::precomputePrt(box.instances, settings);
    const std::vector<glm::dvec3> s = unitIrradianceTransfer(data);
    for (float value : data.uncompressed) ASSERT_GE(value, 0.0f);
    int checked = 0;
    for (std::size_t x = 0; x < data.exitCount(); ++x) {
        if (!interiorOfBoxFace(data.exitPositions[x])) continue;
        ++checked;
        for (int c = 0; c < 3; ++c) EXPECT_LT(s[x][c], bound) << "exit " << x;
    }
    EXPECT_EQ(checked, 5 * 9);
    // The average is well inside the bound: a box open at the top keeps a fraction of the light, and the
    // replicas' 5-sigma band (as in the furnace) lies below the closed box's value.
    const Replicas r = replicateAverage(box, settings, 8, interiorOfBoxFace);
    for (int c = 0; c < 3; ++c) {
        EXPECT_LT(r.mean[c] + 5.0 * r.standardError[c], bound);
        EXPECT_GT(r.mean[c], 0.1 * bound) << "an open box still interreflects";
    }
}

// Clustered PCA: per cluster the rank-D reconstruction's squared Frobenius error equals the sum of the
// discarded squared singular values (Eckart-Young), so the total error is that sum and shrinks with D.
TEST(PrtPca, ReconstructionErrorIsTheDiscardedSingularValues) {
    const PrtScene box = insideBox(3, glm::vec3(0.5f, 0.6f, 0.4f), false, glm::vec3(0.8f, 0.2f, 0.2f));
    gi::MultiscalePrtSettings settings = transferSettings();
    settings.entryPoints = 96;
    settings.clusters = 3;
    settings.minConnectionDistance = 1e-3f;
    double previous = std::numeric_limits<double>::infinity();
    for (int D : {0, 1, 2, 4, 8, 16, 64}) {
        settings.basisVectors = D;
        const gi::PrtData data = gi::precomputePrt(box.instances, settings);
        ASSERT_EQ(data.basisVectors, D);
        const std::size_t mapSize = 3 * data.exitCount();
        std::vector<float> reconstructed(mapSize);
        double error2 = 0.0, total2 = 0.0;
        for (std::size_t e = 0; e < data.entryCount(); ++e) {
            gi::reconstructTransferInto(data, e, reconstructed);
            for (std::size_t j = 0; j < mapSize; ++j) {
                const double t = double(data.uncompressed[e * mapSize + j]);
                error2 += (t - double(reconstructed[j])) * (t - double(reconstructed[j]));
                total2 += t * t;
            }
        }
        double discarded2 = 0.0;
        for (std::uint32_t c = 0; c < data.clusterCount; ++c)
            for (std::uint32_t k = data.singularValueOffsets[c] + std::uint32_t(D);
                 k < data.singularValueOffsets[c + 1]; ++k)
                discarded2 += double(data.singularValues[k]) * double(data.singularValues[k]);
        // Float storage: each reconstructed value carries ~(D + 2) roundings of 2^-24 relative to |T|, so the
        // squared error may differ from the exact one by (D + 2)^2 2^-48 |T|^2 < 1.5e-10 |T|^2 for D <= 64; the
        // singular values themselves are stored as floats (relative 2^-24, squared 2^-23 ~ 1.2e-7).
        const double tolerance = 1.5e-10 * total2 + 1e-6 * discarded2;
        EXPECT_NEAR(error2, discarded2, tolerance) << "D = " << D;
        EXPECT_LE(error2, previous + tolerance) << "D = " << D;
        previous = error2;
        if (D == 0) {
            EXPECT_GT(discarded2, 1e-3 * total2) << "the transfer differs between the entries of a cluster";
        }
        if (D == 64) { // a centred cluster of n entries has rank <= n - 1: D = 64 is exact for n <= 65
            for (std::uint32_t c = 0; c < data.clusterCount; ++c)
                ASSERT_LE(std::count(data.entryCluster.begin(), data.entryCluster.end(), c), 65);
            EXPECT_LT(error2, 1e-9 * total2);
        }
    }
}

// No virtual content: an empty transfer that the run-time functions accept, not an error.
TEST(PrtPrecompute, NoMeshesGiveAnEmptyTransfer) {
    const gi::PrtData data = gi::precomputePrt({}, transferSettings());
    EXPECT_EQ(data.exitCount(), 0u);
    EXPECT_EQ(data.entryCount(), 0u);
    EXPECT_EQ(data.clusterCount, 0u);
    std::vector<glm::vec3> none;
    gi::prtEntryIrradianceInto(data, {}, none);
    gi::prtExitIrradianceInto(data, {}, none, none);
}

// Obscurances of a plane: no ray from its points hits anything, W = 1 exactly.
TEST(PrtObscurance, PlaneIsOne) {
    PrtScene plane;
    plane.add(quadGrid({-1, -1, 0}, {2, 0, 0}, {0, 2, 0}, 4), glm::vec3(0.3f, 0.6f, 0.9f));
    gi::MultiscalePrtSettings settings = transferSettings();
    settings.obscuranceDistance = 10.0f;
    settings.entryPoints = 32;
    const gi::PrtData data = gi::precomputePrt(plane.instances, settings);
    for (const glm::vec3& w : data.exitObscurance) EXPECT_EQ(w, glm::vec3(1.0f));
    for (const glm::vec3& w : data.entryObscurance) EXPECT_EQ(w, glm::vec3(1.0f));
}

// A concave corner: a floor point 0.3 m in front of a 2 x 2 m wall. Closed directions (those that hit the
// wall) make up the wall's form factor F, the open ones 1 - F, so W = (1 - F) + F rho_wall / a per channel,
// with a the area-weighted mean albedo. F by a separately written midpoint quadrature over the wall.
TEST(PrtObscurance, ConcaveCornerMatchesTheFormFactor) {
    const glm::vec3 floorAlbedo(0.2f, 0.4f, 0.6f), wallAlbedo(0.8f, 0.5f, 0.1f);
    PrtScene corner;
    corner.add(quadGrid({-1, -1, 0}, {2, 0, 0}, {0, 2, 0}, 2), floorAlbedo);  // vertex 4 at the origin
    corner.add(quadGrid({0.3f, -1, 0}, {0, 0, 2}, {0, 2, 0}, 1), wallAlbedo); // x = 0.3, normal -x
    gi::MultiscalePrtSettings settings = transferSettings();
    settings.obscuranceDistance = 100.0f; // beyond the scene: only the wall closes directions
    settings.obscuranceRays = 4096;
    settings.entryPoints = 16;
    const gi::PrtData data = gi::precomputePrt(corner.instances, settings);
    ASSERT_EQ(data.exitPositions[4], glm::vec3(0.0f));
    ASSERT_EQ(data.exitNormals[1 * 0 + 4], glm::vec3(0.0f, 0.0f, 1.0f));
    // F = int_wall cos_p cos_w / (pi r^2) dA = int 0.3 z / (pi r^4) dy dz, r^2 = 0.09 + y^2 + z^2: smooth
    // (r >= 0.3), so 2000^2 midpoint cells are accurate to ~1e-7.
    const int steps = 2000;
    double F = 0.0;
    for (int i = 0; i < steps; ++i)
        for (int j = 0; j < steps; ++j) {
            const double y = -1.0 + 2.0 * (i + 0.5) / steps, z = 2.0 * (j + 0.5) / steps;
            const double r2 = 0.09 + y * y + z * z;
            F += 0.3 * z / (std::numbers::pi * r2 * r2);
        }
    F *= (2.0 / steps) * (2.0 / steps);
    ASSERT_GT(F, 0.3);
    ASSERT_LT(F, 0.5); // an infinite wall would close exactly half of the cosine-weighted hemisphere
    const glm::dvec3 average = (glm::dvec3(floorAlbedo) * 4.0 + glm::dvec3(wallAlbedo) * 4.0) / 8.0;
    for (int c = 0; c < 3; ++c) {
        const double closed = double(wallAlbedo[c]) / average[c];
        const double expected = (1.0 - F) + F * closed;
        // Each ray adds 1 (open, probability 1 - F) or rho / a (closed): the mean of N = 4096 has standard
        // deviation |1 - rho / a| sqrt(F (1 - F) / N); 5 of them (normal: p ~ 6e-7).
        const double sigma = std::abs(1.0 - closed) * std::sqrt(F * (1.0 - F) / 4096.0);
        EXPECT_NEAR(double(data.exitObscurance[4][c]), expected, 5.0 * sigma) << "channel " << c;
    }
}

} // namespace
} // namespace lightskin::test
