// The imperfect-volumes reference (gi/reference/src/ImperfectVolumesReference.cpp) against closed
// forms: SH projection and the cosine-lobe convolution (to 1e-5 against separately written
// quadrature), stratified directions, point sampling of triangles (p(x) = 1/A, binomial bounds),
// the grid, and the whole method on scenes with analytic answers: the AO of an open plane (1), a
// point between two infinite plates, a furnace (closed box of uniform emission and albedo) after
// 1-4 bounces, an empty volume and an all-occupied one.
#include <lightskin/gi/reference/ImperfectVolumesReference.h>

#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace lightskin::test {
namespace {

namespace vol = gi::reference::volumes;
using glm::dvec3;
constexpr double kPi = std::numbers::pi;

// Separately written quadrature of a function over the sphere: midpoint rule in (theta, phi).
// Its error for the kinked max(0, n . w) is O(h^2) ~ (pi / 2000)^2 ~ 2.5e-6 per unit integrand.
template <class F>
double sphereIntegral(F f, int thetaSteps = 2000, int phiSteps = 4000) {
    double sum = 0.0;
    const double dt = kPi / thetaSteps, dp = 2.0 * kPi / phiSteps;
    for (int i = 0; i < thetaSteps; ++i) {
        const double theta = (i + 0.5) * dt, st = std::sin(theta), ct = std::cos(theta);
        for (int j = 0; j < phiSteps; ++j) {
            const double phi = (j + 0.5) * dp;
            sum += f(dvec3(st * std::cos(phi), st * std::sin(phi), ct)) * st;
        }
    }
    return sum * dt * dp;
}

// Real SH written out here (not taken from the reference): Y00 = 1/(2 sqrt pi), Y1m = sqrt(3/(4 pi)) {y, z, x}.
double basis(int k, const dvec3& d) {
    const double c1 = std::sqrt(3.0 / (4.0 * kPi));
    switch (k) {
    case 0:
        return 0.5 / std::sqrt(kPi);
    case 1:
        return c1 * d.y;
    case 2:
        return c1 * d.z;
    default:
        return c1 * d.x;
    }
}

TEST(VolumesReference, ShProjectionOfKnownFunctionsMatchesClosedForms) {
    const auto dirs = vol::stratifiedDirections(1000 * 1000);
    // Constant 1: only Y00, with integral of Y00 = 2 sqrt(pi).
    const vol::Sh4 one = vol::projectSh([](const dvec3&) { return 1.0; }, dirs);
    // Exact but for rounding: 10^6 summands of ~0.28 each, relative 1.1e-16 per addition: < 1e-9.
    EXPECT_NEAR(one[0], 2.0 * std::sqrt(kPi), 1e-9);
    for (int k = 1; k < 4; ++k) EXPECT_NEAR(one[std::size_t(k)], 0.0, 1e-9) << k;
    // Linear a . w: integral of w_i w_j = 4 pi / 3 delta_ij, so lambda_1m = sqrt(3/(4 pi)) 4 pi / 3 a_m.
    const dvec3 a(0.3, -0.7, 0.2);
    // Eq. 3 on 1000 bands is a midpoint rule in z: O(h^2) = O((2/1000)^2) relative for w_i w_j.
    const vol::Sh4 lin = vol::projectSh([&](const dvec3& w) { return glm::dot(a, w); }, dirs);
    const double c = std::sqrt(3.0 / (4.0 * kPi)) * 4.0 * kPi / 3.0;
    EXPECT_NEAR(lin[0], 0.0, 1e-9);
    for (std::size_t k = 1; k < 4; ++k) EXPECT_NEAR(lin[k], c * (k == 1 ? a.y : k == 2 ? a.z : a.x), 1e-5) << k;
    // Clamped cosine about a tilted n (Funk-Hecke): sqrt(pi)/2 and sqrt(pi/3) n_m; eq. 3 with 10^6
    // cells of 4 pi / 10^6 sr resolves the kink to ~1e-6.
    const dvec3 n = glm::normalize(dvec3(0.3, -0.4, 0.866));
    const vol::Sh4 lobe = vol::projectSh([&](const dvec3& w) { return std::max(0.0, glm::dot(n, w)); }, dirs);
    const double closed[4] = {std::sqrt(kPi) / 2.0, std::sqrt(kPi / 3.0) * n.y, std::sqrt(kPi / 3.0) * n.z,
                              std::sqrt(kPi / 3.0) * n.x};
    for (std::size_t k = 0; k < 4; ++k) {
        EXPECT_NEAR(lobe[k], closed[k], 1e-5) << k;
        EXPECT_NEAR(vol::shCosineLobe(n)[k], closed[k], 1e-12) << k;
        // The same coefficient by the independent quadrature.
        EXPECT_NEAR(sphereIntegral([&](const dvec3& w) { return std::max(0.0, glm::dot(n, w)) * basis(int(k), w); },
                                   1000, 2000),
                    closed[k], 1e-5)
            << k;
    }
}

TEST(VolumesReference, CosineLobeConvolutionGivesTheIrradianceOfL1Radiance) {
    const dvec3 n = glm::normalize(dvec3(-0.5, 0.2, 0.7));
    const double c0 = 0.8;
    const dvec3 a(0.1, -0.25, 0.3); // L(w) = c0 + a . w >= 0
    // Its SH written from the closed forms above.
    const double c1 = std::sqrt(3.0 / (4.0 * kPi)) * 4.0 * kPi / 3.0;
    const vol::Sh4 sh{c0 * 2.0 * std::sqrt(kPi), c1 * a.y, c1 * a.z, c1 * a.x};
    // Closed form: integral of (c0 + a . w) max(0, n . w) = pi c0 + 2 pi / 3 a . n.
    const double closed = kPi * c0 + 2.0 * kPi / 3.0 * glm::dot(a, n);
    EXPECT_NEAR(vol::shIrradiance(sh, n), closed, 1e-12);
    const double quadrature =
        sphereIntegral([&](const dvec3& w) { return (c0 + glm::dot(a, w)) * std::max(0.0, glm::dot(n, w)); });
    EXPECT_NEAR(quadrature, closed, 1e-5);
    // A hemisphere of radiance 1 about n has irradiance pi; its L1 projection gives exactly that
    // (the clamped cosine has no odd band above 1, the step no even band above 0).
    const vol::Sh4 step{std::sqrt(kPi), std::sqrt(3.0 * kPi) / 2.0 * n.y, std::sqrt(3.0 * kPi) / 2.0 * n.z,
                        std::sqrt(3.0 * kPi) / 2.0 * n.x};
    EXPECT_NEAR(vol::shIrradiance(step, n), kPi, 1e-12);
    EXPECT_NEAR(vol::shIrradiance(step, -n), 0.0, 1e-12);
    // Evaluating the SH of a linear function gives it back (it lies in the span).
    const dvec3 w = glm::normalize(dvec3(1, 2, -3));
    EXPECT_NEAR(vol::shEvaluate(sh, w), c0 + glm::dot(a, w), 1e-12);
}

TEST(VolumesReference, StratifiedDirectionsAreUnitAndBalanced) {
    for (int count : {1, 7, 64, 100, 101, 1000}) {
        const auto dirs = vol::stratifiedDirections(count, 0.3);
        ASSERT_EQ(dirs.size(), std::size_t(count));
        dvec3 sum(0.0);
        for (const dvec3& d : dirs) {
            EXPECT_NEAR(glm::length(d), 1.0, 1e-12);
            sum += d;
        }
        // z: band centres are symmetric about 0 (mean exactly 0); x, y: >= 2 cells per band from 7 on.
        EXPECT_NEAR(sum.z, 0.0, 1e-9) << count;
        if (count >= 7) {
            EXPECT_NEAR(sum.x, 0.0, 1e-9) << count;
            EXPECT_NEAR(sum.y, 0.0, 1e-9) << count;
        }
    }
}

TEST(VolumesReference, TrianglePointsAreUniformOnTheTriangle) {
    TriangleMesh mesh;
    mesh.positions = {{0, 0, 0}, {2, 0, 0}, {0, 1, 0}};
    mesh.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
    mesh.indices = {0, 1, 2};
    const glm::dmat4 world_T_model =
        glm::rotate(glm::translate(glm::dmat4(1.0), dvec3(1, 2, 3)), kPi / 2.0, dvec3(0, 0, 1));
    const int count = 40000;
    const auto points = vol::sampleTriangles(mesh, world_T_model, count, dvec3(0.5), 7u);
    ASSERT_EQ(points.size(), std::size_t(count));
    // The four half-size sub-triangles (corner i: barycentric w_i > 1/2; the middle one) have 1/4
    // of the area each: binomial sigma = sqrt(1/4 * 3/4 / 40000) = 0.0022; 5 sigma = 0.011.
    int bins[4] = {0, 0, 0, 0};
    const glm::dmat4 model_T_world = glm::inverse(world_T_model);
    for (const auto& p : points) {
        const dvec3 m = dvec3(model_T_world * glm::dvec4(p.position, 1.0));
        EXPECT_NEAR(m.z, 0.0, 1e-12);
        const double w1 = m.x / 2.0, w2 = m.y, w0 = 1.0 - w1 - w2;
        ASSERT_GE(std::min({w0, w1, w2}), -1e-12);
        bins[w0 > 0.5 ? 0 : w1 > 0.5 ? 1 : w2 > 0.5 ? 2 : 3]++;
        EXPECT_NEAR(glm::dot(p.normal, dvec3(0, 0, 1)), 1.0, 1e-12); // rotation about z keeps +z
        EXPECT_FALSE(p.emits);
    }
    for (int b = 0; b < 4; ++b) EXPECT_NEAR(bins[b] / double(count), 0.25, 0.011) << b;
}

TEST(VolumesReference, GridIndexingRoundTrips) {
    const vol::Grid g{dvec3(-1.0, 0.5, 2.0), 0.25, 8};
    EXPECT_EQ(g.voxelCount(), 512u);
    for (const glm::ivec3 v : {glm::ivec3(0, 0, 0), glm::ivec3(7, 3, 5), glm::ivec3(7, 7, 7)}) {
        EXPECT_EQ(g.voxelOf(g.centre(v)), v);
        EXPECT_TRUE(g.inside(v));
    }
    EXPECT_EQ(g.index(glm::ivec3(1, 2, 3)), std::size_t((3 * 8 + 2) * 8 + 1));
    EXPECT_FALSE(g.inside(g.voxelOf(dvec3(-1.01, 1.0, 2.1))));
    EXPECT_FALSE(g.inside(g.voxelOf(dvec3(0.0, 1.0, 4.0)))); // the maximum face is outside
}

// One emitting point at the centre of every voxel of layer z = k, normal n.
void addLayer(vol::Volume& volume, int k, const dvec3& n, const dvec3& radiance) {
    std::vector<vol::SurfacePoint> points;
    for (int y = 0; y < volume.grid.resolution; ++y)
        for (int x = 0; x < volume.grid.resolution; ++x)
            points.push_back({volume.grid.centre({x, y, k}), n, radiance, dvec3(0.0), true});
    volume.inject(points);
}

// The incoming SH of the eight voxels around p + s/2 n only (the rest stays 0): enough for
// reconstructIrradiance at p, and cheap on big grids.
std::vector<vol::RgbSh> gatherAround(const vol::Volume& volume, const dvec3& p, const dvec3& n,
                                     std::span<const dvec3> dirs, const vol::MarchSettings& march) {
    std::vector<dvec3> exitant(volume.grid.voxelCount());
    for (std::size_t i = 0; i < exitant.size(); ++i) exitant[i] = volume.radiance(i);
    std::vector<vol::RgbSh> incoming(volume.grid.voxelCount());
    const dvec3 q = (p + 0.5 * volume.grid.voxelSize * n - volume.grid.origin) / volume.grid.voxelSize - 0.5;
    const glm::ivec3 base(int(std::floor(q.x)), int(std::floor(q.y)), int(std::floor(q.z)));
    for (int c = 0; c < 8; ++c) {
        const glm::ivec3 v = base + glm::ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        if (volume.grid.inside(v)) incoming[volume.grid.index(v)] = vol::gatherVoxel(volume, exitant, v, dirs, march);
    }
    return incoming;
}

TEST(VolumesReference, AmbientOcclusionOfAnOpenPlaneIsOne) {
    // 32^3 grid of 5 cm voxels; plane = layer 4. The receivers' rays start one voxel above the
    // plane; the shallowest downward band (z = -0.1 for 100 directions) meets the plane within
    // 10 voxels, inside the grid from its centre, so every downward ray is blocked and every upward
    // one escapes: the visibility is exactly the upper hemisphere, whose L1 irradiance is exactly
    // pi (see above). Left: float rounding of the sums (1e-12).
    vol::Volume volume(vol::Grid{dvec3(0.0), 0.05, 32});
    addLayer(volume, 4, dvec3(0, 0, 1), dvec3(1.0));
    const auto dirs = vol::stratifiedDirections(100);
    const vol::MarchSettings ao{std::numeric_limits<double>::infinity(), true};
    for (const dvec3 p : {volume.grid.centre({16, 16, 4}), volume.grid.centre({16, 16, 4}) + dvec3(0.013, -0.021, 0)}) {
        const auto incoming = gatherAround(volume, p, dvec3(0, 0, 1), dirs, ao);
        const dvec3 e = vol::reconstructIrradiance(volume, incoming, p, dvec3(0, 0, 1));
        EXPECT_NEAR(e.x / kPi, 1.0, 1e-12);
        // The same plane seen from below: the receivers below see the plane above; downward rays
        // escape, so a downward-facing point on the plane's underside is unoccluded too.
        const auto below = gatherAround(volume, p, dvec3(0, 0, -1), dirs, ao);
        EXPECT_NEAR(vol::reconstructIrradiance(volume, below, p, dvec3(0, 0, -1)).x / kPi, 1.0, 1e-12);
    }
}

TEST(VolumesReference, PointBetweenTwoInfinitePlatesSeesOnlyTheOppositePlate) {
    // 64^3 grid; plates at layers 4 (normal +z, radiance Lb) and 8 (normal -z, Lt). A point on the
    // lower plate facing up: all its upper hemisphere is the upper plate, so E = pi Lt exactly,
    // whatever Lb (the receivers also see the lower plate's front below them: the L1 lobe of a
    // lower hemisphere integrates to 0 against the upper clamped cosine). Rays from layer 5 meet
    // layer 8 within 2.5 / 0.1 = 25 voxels horizontally: inside the grid from its centre.
    vol::Volume volume(vol::Grid{dvec3(-1.6), 0.05, 64});
    const dvec3 lb(0.3, 0.6, 0.9), lt(2.0, 1.0, 0.5);
    addLayer(volume, 4, dvec3(0, 0, 1), lb);
    addLayer(volume, 8, dvec3(0, 0, -1), lt);
    const auto dirs = vol::stratifiedDirections(100);
    const dvec3 p = volume.grid.centre({32, 32, 4});
    const auto incoming = gatherAround(volume, p, dvec3(0, 0, 1), dirs, {});
    const dvec3 e = vol::reconstructIrradiance(volume, incoming, p, dvec3(0, 0, 1));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(e[c], kPi * lt[c], 1e-12 * kPi * lt[c]) << c;
    // The upper plate's underside sees the lower plate the same way.
    const dvec3 q = volume.grid.centre({30, 33, 8});
    const auto down = gatherAround(volume, q, dvec3(0, 0, -1), dirs, {});
    const dvec3 eq = vol::reconstructIrradiance(volume, down, q, dvec3(0, 0, -1));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(eq[c], kPi * lb[c], 1e-12 * kPi * lb[c]) << c;
    // Ambient occlusion between the plates: every ray is blocked.
    const auto ao = gatherAround(volume, p, dvec3(0, 0, 1), dirs, {std::numeric_limits<double>::infinity(), true});
    EXPECT_NEAR(vol::reconstructIrradiance(volume, ao, p, dvec3(0, 0, 1)).x, 0.0, 1e-12);
    // The plates seen from behind emit nothing: a downward point on the lower plate's underside.
    const auto behind = gatherAround(volume, p, dvec3(0, 0, -1), dirs, {});
    EXPECT_NEAR(vol::reconstructIrradiance(volume, behind, p, dvec3(0, 0, -1)).x, 0.0, 1e-12);
}

TEST(VolumesReference, FurnaceBoxHasTheAnalyticRadianceAfterEachBounce) {
    // A closed box: the outer shell of an 8^3 grid, inward normals (edge and corner voxels get one
    // point per wall), emitted radiance Le, albedo a. Every ray from an inside voxel hits the shell's
    // front (a one-voxel step cannot cross a one-voxel layer), so after n passes the incoming radiance
    // is uniform, L_n = Le (1 + a + ... + a^(n-1)), and a wall point receives E = pi L_n.
    const int r = 8;
    vol::Volume volume(vol::Grid{dvec3(0.0), 0.1, r});
    const dvec3 le(1.0, 0.5, 2.0), albedo(0.3, 0.5, 0.8);
    std::vector<vol::SurfacePoint> points;
    for (int z = 0; z < r; ++z)
        for (int y = 0; y < r; ++y)
            for (int x = 0; x < r; ++x) {
                const glm::ivec3 v(x, y, z);
                for (int axis = 0; axis < 3; ++axis)
                    for (int side : {0, r - 1}) {
                        if (v[axis] != side) continue;
                        dvec3 n(0.0);
                        n[axis] = side == 0 ? 1.0 : -1.0;
                        points.push_back({volume.grid.centre(v), n, le, albedo, true});
                    }
            }
    volume.inject(points);
    const auto dirs = vol::stratifiedDirections(100);
    for (int bounces = 1; bounces <= 4; ++bounces) {
        const auto incoming = vol::solve(volume, dirs, bounces, {});
        dvec3 expected(0.0);
        for (int k = 0; k < bounces; ++k) expected += le * glm::pow(albedo, dvec3(double(k)));
        // A wall centre, a point near an edge and one near a corner, each with its wall's normal.
        const struct {
            dvec3 p, n;
        } receivers[] = {{dvec3(0.4, 0.43, 0.05), dvec3(0, 0, 1)},
                         {dvec3(0.11, 0.4, 0.75), dvec3(0, 0, -1)},
                         {dvec3(0.05, 0.62, 0.64), dvec3(1, 0, 0)}};
        for (const auto& receiver : receivers) {
            const dvec3 e = vol::reconstructIrradiance(volume, incoming, receiver.p, receiver.n);
            for (int c = 0; c < 3; ++c) EXPECT_NEAR(e[c] / kPi, expected[c], 1e-12 * expected[c]) << bounces;
        }
    }
}

TEST(VolumesReference, EmptyAndFullVolumes) {
    const auto dirs = vol::stratifiedDirections(16);
    // Empty: no light and no occlusion.
    vol::Volume empty(vol::Grid{dvec3(0.0), 0.1, 4});
    const auto none = vol::solve(empty, dirs, 2, {});
    EXPECT_EQ(vol::reconstructIrradiance(empty, none, dvec3(0.2), dvec3(0, 0, 1)), dvec3(0.0));
    const auto open = vol::solve(empty, dirs, 1, {std::numeric_limits<double>::infinity(), true});
    EXPECT_NEAR(vol::reconstructIrradiance(empty, open, dvec3(0.2), dvec3(0, 0, 1)).x / kPi, 1.0, 1e-12);
    // All occupied, uniform radiance L seen from every side (no net normal): every ray hits a
    // neighbour, so each voxel sees L everywhere and E = pi L; AO is 0.
    // A 6^3 grid and a receiver whose eight voxels are inside ones (border voxels' outward rays leave).
    vol::Volume full(vol::Grid{dvec3(0.0), 0.1, 6});
    std::vector<vol::SurfacePoint> points;
    for (int i = 0; i < 216; ++i) {
        const dvec3 c = full.grid.centre({i % 6, (i / 6) % 6, i / 36});
        points.push_back({c, dvec3(0, 0, 1), dvec3(0.7), dvec3(0.0), true});
        points.push_back({c, dvec3(0, 0, -1), dvec3(0.7), dvec3(0.0), true});
    }
    full.inject(points);
    const auto lit = vol::solve(full, dirs, 1, {});
    const dvec3 e = vol::reconstructIrradiance(full, lit, dvec3(0.25, 0.25, 0.2), dvec3(0, 0, 1));
    EXPECT_NEAR(e.x, kPi * 0.7, 1e-12);
    const auto blocked = vol::solve(full, dirs, 1, {std::numeric_limits<double>::infinity(), true});
    EXPECT_NEAR(vol::reconstructIrradiance(full, blocked, dvec3(0.25, 0.25, 0.2), dvec3(0, 0, 1)).x, 0.0, 1e-12);
}

} // namespace
} // namespace lightskin::test
