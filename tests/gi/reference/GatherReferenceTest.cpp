// The double-precision reference and the shared math against analytic results: disc form
// factor, infinite plane, square emitter, energy conservation, resolution invariance, and the
// numerical extremes of the issue (finite, non-negative, bounded, guards exact where stated).
#include "common/GatherTestScenes.h"

#include <lightskin/gi/reference/LightSkinReference.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <numbers>

namespace lightskin::test {
namespace {

namespace ref = gi::reference;
using glm::dvec3;
constexpr double kPi = std::numbers::pi;

double exitance(const gi::VirtualAreaLight& l) { return double(l.flux.x) / double(l.area); }

// Exact form factor of a differential area on the axis of a parallel square of side s at height h.
double squareFormFactor(double s, double h) {
    const double x = s / (2.0 * h);
    const double q = std::sqrt(1.0 + x * x);
    return 4.0 / kPi * x / q * std::atan(x / q);
}

double polygonTolerance(double r, double h);

TEST(GatherReference, SingleCoaxialDiscGivesTheExactDiscFormFactor) {
    for (double h : {1e-3, 0.1, 1.0, 10.0}) {
        const double area = 0.05;
        const auto l = disc({0, 0, float(h)}, {0, 0, -1}, float(area), {2, 2, 2});
        const double r2 = area / kPi;
        // the point model (eq. 3) is exact on the axis; the area model of the near field (G12, h < 4 r)
        // within its polygon's tolerance
        const double point = ref::irradiance(std::span(&l, 1), dvec3(0.0), dvec3(0, 0, 1), 0, false);
        EXPECT_NEAR(point / exitance(l), r2 / (r2 + h * h), 1e-6 * r2 / (r2 + h * h)) << "h = " << h;
        const double e = ref::irradiance(std::span(&l, 1), dvec3(0.0), dvec3(0, 0, 1), 0, true);
        EXPECT_NEAR(e / exitance(l), r2 / (r2 + h * h),
                    h * h < 16.0 * r2 ? polygonTolerance(std::sqrt(r2), h) : 1e-6 * r2 / (r2 + h * h))
            << "h = " << h;
    }
}

// Exact form factor from a differential area parallel to (and facing) a disc of radius r, at
// height h above the disc's plane and lateral offset s from its axis (Howell's catalogue, B-13).
double parallelDiscFormFactor(double r, double h, double s) {
    const double a = h * h + s * s + r * r;
    return 0.5 * (1.0 - (h * h + s * s - r * r) / std::sqrt(a * a - 4.0 * r * r * s * s));
}

// Near field (a VAL nearer to a receiver than its own size), for the point model
// (eq. 3, guard G12 off; G12 itself is checked by the NearFieldArea tests below). The candidate clamp
// "bound the form factor by the disc's exact on-axis form factor r^2 / (r^2 + h^2)" can never bind
// for eq. 3: w cos(theta_i) = r^2 cos(theta_j) cos(theta_i) / (r^2 + d^2) <= r^2 / (r^2 + d^2) <=
// r^2 / (r^2 + h^2) because h <= d. What eq. 3 gets wrong in the near field is the other way round:
// beside the disc's rim, close to its plane, cos(theta_j) = h / d -> 0 while the exact form factor
// stays near 1/2 (half the disc fills half the receiver view): a hole in the light next to a
// near-field VAL, the black brute-force pixel of docs/BENCHMARKS.md. Both asserted here, against
// the closed form (not against the shared math).
TEST(GatherReference, PointModelNearFieldDiscIsBoundedByTheOnAxisFormFactorAndUnderestimatedBesideItsRim) {
    const double area = 1e-4, r = std::sqrt(area / kPi); // a VAL of 1 cm^2 (stride 4 at ~1.3 m)
    const auto l = disc({0, 0, 0}, {0, 0, 1}, float(area), {1, 1, 1});
    const double m = exitance(l);
    std::uint32_t state = 12345u; // a small LCG: random receivers within 2 r, random normals
    const auto uniform = [&state] {
        state = state * 1664525u + 1013904223u;
        return double(state >> 8) / double(1u << 24);
    };
    int lit = 0;
    for (int i = 0; i < 2000; ++i) {
        const dvec3 x(r * (4.0 * uniform() - 2.0), r * (4.0 * uniform() - 2.0), r * 2.0 * uniform() + 1e-6);
        const dvec3 n = glm::normalize(dvec3(2.0 * uniform() - 1.0, 2.0 * uniform() - 1.0, -uniform()));
        const double f = ref::irradiance(std::span(&l, 1), x, n, 0, false) / m;
        // float VAL storage (6e-8 relative) bounds the rounding of the comparison
        EXPECT_LE(f, r * r / (r * r + x.z * x.z) * (1.0 + 1e-6)) << "receiver " << x.x << "," << x.y << "," << x.z;
        lit += f > 0.0;
    }
    EXPECT_GT(lit, 500); // about half the normals face the disc: not a pass on all-zero output
    // On the axis, facing the disc: eq. 3 is the exact form factor (the closed form above at s = 0).
    for (double h : {0.1 * r, r, 3.0 * r}) {
        const double f = ref::irradiance(std::span(&l, 1), dvec3(0, 0, h), dvec3(0, 0, -1), 0, false) / m;
        EXPECT_NEAR(f, parallelDiscFormFactor(r, h, 0.0), 1e-6) << "h = " << h / r << " r";
    }
    // Facing the disc, 0.1 r above its plane, over its rim (s = r): exact 0.475, eq. 3 gives
    // r^2 (h/d)^2 / (r^2 + d^2) = 0.0049 (d^2 = 1.01 r^2), i.e. < 2 % of it.
    const double h = 0.1 * r;
    const double exact = parallelDiscFormFactor(r, h, r);
    const double model = ref::irradiance(std::span(&l, 1), dvec3(r, 0, h), dvec3(0, 0, -1), 0, false) / m;
    EXPECT_NEAR(exact, 0.475, 0.001);
    EXPECT_NEAR(model, 0.01 / 1.01 / 2.01, 1e-4);
    EXPECT_LT(model, 0.02 * exact);
}

// ---- Guard G12: near-field VALs as areas (lightskin_math.glsl), against independent references ----

// Exact form factor from a differential area at height h above the plane of a disc of radius r,
// lateral offset s > r from its axis, its normal parallel to the disc's plane and pointing at the
// axis (Howell's catalogue, B-14; the element's plane does not cut the disc).
double perpendicularDiscFormFactor(double r, double h, double s) {
    const double hh = h / s, rr = r / s, z = 1.0 + hh * hh + rr * rr;
    return 0.5 * hh * (z / std::sqrt(z * z - 4.0 * rr * rr) - 1.0);
}

// The disc form factor from x (unit normal n) by a midpoint rule on a polar grid of rings x rings
// cells over the disc (centre 0, normal +z, radius r), with the receiver's horizon and the disc's
// one-sidedness applied per cell: written from the definition F = int cos_i+ cos_j+ / (pi d^2) dA,
// sharing nothing with the polygon of lightskin_math.glsl.
double quadratureFormFactor(double r, const dvec3& x, const dvec3& n, int rings) {
    const int sectors = rings;
    double sum = 0.0;
    for (int i = 0; i < rings; ++i) {
        const double r0 = r * i / rings, r1 = r * (i + 1) / rings, rho = 0.5 * (r0 + r1);
        const double cellArea = kPi * (r1 * r1 - r0 * r0) / sectors;
        for (int j = 0; j < sectors; ++j) {
            const double phi = 2.0 * kPi * (j + 0.5) / sectors;
            const dvec3 v = dvec3(rho * std::cos(phi), rho * std::sin(phi), 0.0) - x; // x -> cell
            const double d2 = glm::dot(v, v);
            const double cosI = glm::dot(n, v), cosJ = -v.z; // both times d
            if (cosI > 0.0 && cosJ > 0.0) sum += cosI * cosJ / (kPi * d2 * d2) * cellArea;
        }
    }
    return sum;
}

// The 32-gon of G12 lies within delta = 0.0033 r of the circle (circumradius 1.00322 r, apothem
// 0.99839 r); moving the boundary by delta changes the form factor by at most delta times the
// integral of the kernel cos(theta_j) / (pi d^2) <= h / (pi d^3) along the rim, <= 2 delta / (pi h) at
// height h above the disc's plane. Plus float storage of the VAL (6e-8 relative).
double polygonTolerance(double r, double h) { return 2.0 * 0.0033 * r / (kPi * h) + 1e-6; }

TEST(GatherReference, NearFieldAreaMatchesHowellsParallelDisc) {
    const double area = 1e-4, r = std::sqrt(area / kPi);
    const auto l = disc({0, 0, 0}, {0, 0, 1}, float(area), {1, 1, 1});
    const double m = exitance(l);
    // (h, s) in units of r: beside the rim 0.1 r and 0.05 r above the plane (point model: 0.0049 where
    // the disc gives 0.475), over the disc, just outside the rim, and at the switch distance.
    const double cases[][2] = {{0.1, 1.0}, {0.05, 1.0}, {0.1, 0.5}, {0.05, 0.9}, {0.1, 1.2},
                               {0.5, 1.0}, {1.0, 2.0},  {0.3, 0.0}, {2.0, 3.0},  {0.2, 3.5}};
    for (const auto& c : cases)
        for (double azimuth : {0.0, 0.3, 1.9}) { // the polygon's vertices and edges lie at different angles
            const double h = c[0] * r, s = c[1] * r;
            const dvec3 x(s * std::cos(azimuth), s * std::sin(azimuth), h);
            const double f = ref::irradiance(std::span(&l, 1), x, dvec3(0, 0, -1), 0, true) / m;
            EXPECT_NEAR(f, parallelDiscFormFactor(r, h, s), polygonTolerance(r, h))
                << "h = " << c[0] << " r, s = " << c[1] << " r, azimuth " << azimuth;
        }
    // beside the rim, 0.1 r above the plane: exact 0.475, within 1 %
    const double f = ref::irradiance(std::span(&l, 1), dvec3(r, 0, 0.1 * r), dvec3(0, 0, -1), 0, true) / m;
    EXPECT_NEAR(f, 0.475, 0.475 * 0.01);
}

TEST(GatherReference, NearFieldAreaMatchesHowellsPerpendicularElement) {
    const double area = 1e-4, r = std::sqrt(area / kPi);
    const auto l = disc({0, 0, 0}, {0, 0, 1}, float(area), {1, 1, 1});
    const double m = exitance(l);
    const double cases[][2] = {{0.2, 1.1}, {0.05, 1.05}, {0.5, 2.0}, {1.0, 1.5}, {1.5, 3.0}};
    for (const auto& c : cases) {
        const double h = c[0] * r, s = c[1] * r;
        const double f = ref::irradiance(std::span(&l, 1), dvec3(s, 0, h), dvec3(-1, 0, 0), 0, true) / m;
        const double exact = perpendicularDiscFormFactor(r, h, s);
        EXPECT_GT(exact, 0.01);
        EXPECT_NEAR(f, exact, polygonTolerance(r, h)) << "h = " << c[0] << " r, s = " << c[1] << " r";
    }
}

TEST(GatherReference, NearFieldAreaMatchesQuadratureAtTiltedAndClippedReceivers) {
    const double area = 1e-4, r = std::sqrt(area / kPi);
    const auto l = disc({0, 0, 0}, {0, 0, 1}, float(area), {1, 1, 1});
    const double m = exitance(l);
    struct Case {
        dvec3 x; // units of r
        dvec3 n; // normalised below
        const char* what;
    };
    const Case cases[] = {
        {{0.0, 0.0, 0.5}, {0.0, 0.0, -1.0}, "on the axis, facing"},
        {{0.3, 0.2, 0.4}, {0.5, 0.0, -1.0}, "over the disc, tilted 27 deg"},
        {{0.3, 0.2, 0.4}, {-1.0, 0.3, -0.6}, "over the disc, tilted 60 deg"},
        {{0.0, 0.0, 0.3}, {1.0, 0.0, 0.0}, "over the centre, normal in the disc's plane: the plane halves the disc"},
        {{0.5, 0.0, 0.2}, {-1.0, 0.0, 0.3}, "over the disc, the tangent plane cuts it near the receiver"},
        {{1.0, 0.0, 0.1}, {-0.2, 0.0, -1.0}, "beside the rim, 0.1 r up, tilted toward the disc"},
        {{1.0, 0.0, 0.1}, {0.6, 0.0, -1.0}, "beside the rim, 0.1 r up, tilted away: the plane cuts the disc"},
        {{1.5, 0.5, 0.3}, {-1.0, 0.0, 0.2}, "outside the rim, nearly perpendicular"},
        {{0.7, 0.0, 0.2}, {1.0, 0.0, 0.1}, "the centre below the horizon, a cap of the disc above it"},
        {{-2.0, 1.0, 1.0}, {0.3, -0.2, -1.0}, "at 2.4 r, tilted"},
        {{0.2, 0.1, 0.2}, {0.0, 0.3, 1.0}, "facing away: below the horizon, 0"},
    };
    int lit = 0;
    for (const Case& c : cases) {
        const dvec3 x = c.x * r, n = glm::normalize(c.n);
        const double f = ref::irradiance(std::span(&l, 1), x, n, 0, true) / m;
        const double fine = quadratureFormFactor(r, x, n, 1000), coarse = quadratureFormFactor(r, x, n, 500);
        // the midpoint rule's error, estimated by halving the cells (it shrinks at least linearly at
        // the horizon's kink, quadratically elsewhere: the fine grid's error <= |fine - coarse|)
        const double tolerance = polygonTolerance(r, x.z) + std::abs(fine - coarse) + 1e-6;
        EXPECT_NEAR(f, fine, tolerance) << c.what;
        EXPECT_GE(f, 0.0) << c.what;
        lit += fine > 0.01;
    }
    EXPECT_GE(lit, 9); // all but the receiver facing away (and perhaps the small cap)
    // Behind the VAL (one-sided): 0 from both models.
    EXPECT_EQ(ref::irradiance(std::span(&l, 1), dvec3(0.2, 0.0, -0.1) * r, dvec3(0, 0, 1), 0, true), 0.0);
}

// The area model's irradiance vector also gives the glossy channel (eq. 5): w = |Phi| and the lobe
// along Phi. For a receiver facing a coaxial disc Phi is along the axis: w = the exact form factor,
// and a mirror-direction eye sees the lobe's peak.
TEST(GatherReference, NearFieldAreaGlossyWeightIsTheFormFactorOnTheAxis) {
    const double area = 1e-4, r = std::sqrt(area / kPi), h = 0.5 * r;
    const auto l = disc({0, 0, 0}, {0, 0, 1}, float(area), {1, 1, 1});
    const double m = exitance(l);
    ref::Surface surface;
    surface.position = dvec3(0, 0, h);
    surface.normal = dvec3(0, 0, -1);
    surface.diffuseAlbedo = dvec3(0.0);
    surface.specular = dvec3(1.0);
    surface.exponent = 10.0;
    ref::GatherParameters parameters;
    parameters.epsilonL = 0.0;
    parameters.nearField = true;
    const dvec3 eye(0, 0, -1.0); // on the axis below: the mirror direction of the disc's axis
    const double glossy = ref::bruteForce(std::span(&l, 1), surface, eye, parameters).x / m;
    // c_k M w cos^k(0) with c_k = (k + 1) / (2 pi), w = r^2 / (r^2 + h^2)
    const double expected = (surface.exponent + 1.0) / (2.0 * kPi) * parallelDiscFormFactor(r, h, 0.0);
    EXPECT_NEAR(glossy, expected, expected * polygonTolerance(r, h) / parallelDiscFormFactor(r, h, 0.0));
}

TEST(GatherReference, FinelyDiscretisedDiscConvergesToTheDiscFormFactor) {
    // Independent of eq. 3 for the big disc: many small discs (near-point sources) on a polar grid.
    const double radius = 1.0, h = 0.7;
    std::vector<gi::VirtualAreaLight> vals;
    const int rings = 400, sectors = 400;
    for (int i = 0; i < rings; ++i) {
        const double r0 = radius * i / rings, r1 = radius * (i + 1) / rings;
        const double area = kPi * (r1 * r1 - r0 * r0) / sectors;
        for (int j = 0; j < sectors; ++j) {
            const double phi = 2.0 * kPi * (j + 0.5) / sectors;
            const double r = 0.5 * (r0 + r1);
            vals.push_back(disc({float(r * std::cos(phi)), float(r * std::sin(phi)), float(h)}, {0, 0, -1}, float(area),
                                glm::vec3(float(area))));
        }
    }
    const double e = ref::irradiance(vals, dvec3(0.0), dvec3(0, 0, 1));
    EXPECT_NEAR(e, radius * radius / (radius * radius + h * h), 2e-3);
}

TEST(GatherReference, LargeUniformPlaneGivesPiTimesRadiance) {
    const double radiance = 0.8, h = 1.0;
    double previousError = 1.0;
    for (float size : {6.0f, 20.0f, 60.0f}) {
        // cells of 0.1 h: the disc approximation of each cell is then within ~0.3 %
        const auto vals =
            squareEmitter({0, 0, float(h)}, {0, 0, -1}, size, int(size * 10.0f), glm::vec3(float(radiance)));
        const double e = ref::irradiance(vals, dvec3(0.0), dvec3(0, 0, 1));
        const double error = std::abs(e / (kPi * radiance) - 1.0);
        EXPECT_LT(error, previousError) << "must converge as the plane grows";
        EXPECT_NEAR(e / (kPi * radiance), squareFormFactor(size, h), 4e-3) << "finite square of side " << size;
        previousError = error;
    }
    EXPECT_LT(previousError, 5e-3);
}

TEST(GatherReference, MillionValsMatchTheExactSquareFormFactor) {
    const double radiance = 1.5, h = 0.5, side = 1.0;
    const auto vals = squareEmitter({0, 0, float(h)}, {0, 0, -1}, float(side), 1000, glm::vec3(float(radiance)));
    ASSERT_EQ(vals.size(), 1000000u);
    const double e = ref::irradiance(vals, dvec3(0.0), dvec3(0, 0, 1));
    EXPECT_NEAR(e / (kPi * radiance), squareFormFactor(side, h), 1e-4);
}

TEST(GatherReference, HalvingOrDoublingValResolutionChangesTotalLightByAtMostTwoPercent) {
    const auto receiver = makeGrid(2.0f, 20);
    auto total = [&](int resolution) {
        const auto vals = squareEmitter({0.3f, 0.0f, 0.4f}, {-0.3f, 0.1f, -1.0f}, 1.0f, resolution, {1, 1, 1});
        double sum = 0.0;
        for (const glm::vec3& p : receiver.positions) sum += ref::irradiance(vals, dvec3(p), dvec3(0, 0, 1));
        return sum;
    };
    const double base = total(32);
    EXPECT_NEAR(total(16) / base, 1.0, 0.02);
    EXPECT_NEAR(total(64) / base, 1.0, 0.02);
}

TEST(GatherReference, EnergyIsNeverCreated) {
    // Receivers tile a closed sphere around the VALs: received power <= emitted power.
    const TriangleMesh sphere = makeSphere(1.0f, 200, 400);
    std::vector<double> areas(sphere.vertexCount(), 0.0);
    for (std::size_t t = 0; t < sphere.indices.size(); t += 3) {
        const dvec3 a(sphere.positions[sphere.indices[t]]), b(sphere.positions[sphere.indices[t + 1]]),
            c(sphere.positions[sphere.indices[t + 2]]);
        const double area = 0.5 * glm::length(glm::cross(b - a, c - a));
        for (int k = 0; k < 3; ++k) areas[sphere.indices[t + std::size_t(k)]] += area / 3.0;
    }
    for (std::uint32_t seed : {1u, 2u, 3u}) {
        const auto vals = randomVals(20, {-0.5f, -0.5f, -0.5f}, {0.5f, 0.5f, 0.5f}, {0, 0, -3}, 0.01f, seed);
        double emitted = 0.0;
        for (const auto& l : vals) emitted += double(l.flux.x);
        double received = 0.0;
        for (std::size_t v = 0; v < sphere.vertexCount(); ++v)
            received += areas[v] * ref::irradiance(vals, dvec3(sphere.positions[v]), -dvec3(sphere.normals[v]));
        EXPECT_LE(received, emitted * 1.001) << "seed " << seed;
        EXPECT_GT(received, emitted * 0.9) << "a closed receiver must catch nearly all power";
    }
}

// Renormalisation (eq. 8-11): applying the averaged VPLs at the sparse point reproduces eq. 8.
TEST(GatherReference, RenormalisedVplsReproduceTheGatheredRadianceAtTheSparsePoint) {
    const auto vals = randomVals(300, {-1, -1, 0.5f}, {1, 1, 2}, {0, 0, 0}, 0.01f, 7);
    std::vector<ref::Receiver> receivers;
    for (int i = 0; i < 20; ++i) {
        ref::Receiver r;
        r.position = dvec3(0.1 * i - 1.0, 0.05 * i, 0.0);
        r.normal = glm::normalize(dvec3(0.02 * i - 0.2, 0.1, 1.0));
        r.exponent = 1.0 + 10.0 * i;
        receivers.push_back(r);
    }
    const dvec3 eye(0.3, -2.0, 3.0);
    std::vector<ref::GatherSums> sums;
    ref::gatherInto(vals, receivers, eye, {}, sums);
    std::vector<ref::VplPair> vpls;
    ref::renormaliseInto(sums, receivers, eye, vpls);
    for (std::size_t i = 0; i < receivers.size(); ++i) {
        ref::Surface s{receivers[i].position, receivers[i].normal, dvec3(0.7), dvec3(0.3), receivers[i].exponent};
        const dvec3 expected = s.diffuseAlbedo * sums[i].irradiance / kPi + s.specular * sums[i].glossy;
        const dvec3 shaded = ref::shade(vpls[i], s, eye);
        ref::Surface diffuseOnly = s;
        diffuseOnly.specular = dvec3(0.0);
        const dvec3 shadedDiffuse = ref::shade(vpls[i], diffuseOnly, eye);
        const dvec3 brute = ref::bruteForce(vals, s, eye, {});
        for (int c = 0; c < 3; ++c) {
            const double diffuse = s.diffuseAlbedo[c] * sums[i].irradiance[c] / kPi;
            EXPECT_NEAR(shadedDiffuse[c], diffuse, 1e-9 * diffuse) << "point " << i;
            // the glossy lobe at the averaged position may fall below guard G4 (1e-3): then eq. 10
            // underestimates, never overestimates
            EXPECT_LE(shaded[c], expected[c] * (1.0 + 1e-9)) << "point " << i;
            EXPECT_GE(shaded[c], expected[c] * (1.0 - 1e-3)) << "point " << i;
            EXPECT_NEAR(brute[c], expected[c], 1e-9 * expected[c] + 1e-15) << "point " << i;
        }
    }
}

TEST(GatherReference, VertexWeightsNeverProduceNaN) {
    std::vector<ref::Receiver> sparse(3);
    sparse[0].position = dvec3(1, 0, 0);
    sparse[1].position = dvec3(-1, 0, 0);
    sparse[2].position = dvec3(0, 1, 0);
    sparse[2].normal = dvec3(0, 0, -1);
    std::vector<ref::VplPair> vpls(3);
    for (std::size_t i = 0; i < 3; ++i) {
        vpls[i].diffuse.radiance = dvec3(double(i + 1));
        vpls[i].diffuse.position = sparse[i].position + dvec3(0, 0, 1);
    }
    using List = std::array<std::uint32_t, 8>;
    // equidistant (W_v = 0 by eq. 12), a single repeated neighbour, and all facing away
    const std::vector<dvec3> positions{dvec3(0.0), dvec3(0.0), dvec3(0, 1, 0)};
    const std::vector<dvec3> normals{dvec3(0, 0, 1), dvec3(0, 0, 1), dvec3(0, 0, 1)};
    const std::vector<List> neighbours{List{0, 1, 1, 1, 1, 1, 1, 1}, List{1, 1, 1, 1, 1, 1, 1, 1},
                                       List{2, 2, 2, 2, 2, 2, 2, 2}};
    std::vector<ref::VplPair> out;
    ref::interpolateVerticesInto(positions, normals, neighbours, sparse, vpls, out);
    EXPECT_DOUBLE_EQ(out[0].diffuse.radiance.x, 1.5) << "equidistant: normal term alone, equal weights";
    EXPECT_DOUBLE_EQ(out[1].diffuse.radiance.x, 2.0) << "one unique neighbour";
    EXPECT_DOUBLE_EQ(out[2].diffuse.radiance.x, 3.0) << "facing away: nearest neighbour";
}

// G8: two sparse points 20 cm apart whose VPLs lie 1 m away on opposite sides, 5 cm above
// their plane. eq. 13 alone puts the vertex VPL 5 cm above the vertex between them: D = 0.0025 m^2
// against D_j = 1.0025 at the sparse points, so eq. 10 would give 400 L'' at the vertex where each
// sparse point received 0.05 L'' (a blown pixel). The floor raises rbar^2 to Dmin - |v - l|^2 = 1.
TEST(GatherReference, VertexVplIsNeverNearerThanTheNearestGatheredVpl) {
    std::vector<ref::Receiver> sparse(2);
    sparse[0].position = dvec3(0.1, 0, 0);
    sparse[1].position = dvec3(-0.1, 0, 0);
    std::vector<ref::VplPair> vpls(2);
    vpls[0].diffuse.position = dvec3(1.1, 0, 0.05);
    vpls[1].diffuse.position = dvec3(-1.1, 0, 0.05);
    for (auto& v : vpls) v.diffuse.radiance = dvec3(1.0);
    using List = std::array<std::uint32_t, 8>;
    const std::vector<dvec3> positions{dvec3(0.0), dvec3(0.11, 0, 0)};
    const std::vector<dvec3> normals{dvec3(0, 0, 1), dvec3(0, 0, 1)};
    const std::vector<List> neighbours{List{0, 1, 1, 1, 1, 1, 1, 1}, List{0, 0, 0, 0, 0, 0, 0, 0}};
    std::vector<ref::VplPair> out;
    ref::interpolateVerticesInto(positions, normals, neighbours, sparse, vpls, out);
    const double dMin = 1.0 * 1.0 + 0.05 * 0.05; // |x_j - l_j|^2 + rbar_j^2 (rbar = 0)
    EXPECT_NEAR(out[0].diffuse.position.z, 0.05, 1e-12);
    EXPECT_NEAR(out[0].diffuse.r2, dMin - 0.05 * 0.05, 1e-12);
    // eq. 10 at the vertex is now bounded by L / Dmin (cos <= 1), times rho_d / pi.
    const ref::Surface surface{positions[0], normals[0], dvec3(1.0), dvec3(0.0), 1.0};
    const double e = ref::shade(out[0], surface, dvec3(0, 0, 5)).x;
    EXPECT_LE(e, 1.0 / std::numbers::pi / dMin * (1.0 + 1e-12));
    EXPECT_GT(e, 0.0);
    // One neighbour, vertex 1 cm from it toward its VPL: raised by exactly Dmin - |v - l|^2.
    const dvec3 o = out[1].diffuse.position - positions[1];
    EXPECT_GT(dMin - glm::dot(o, o), 0.0);
    EXPECT_NEAR(out[1].diffuse.r2, dMin - glm::dot(o, o), 1e-12);
    // A vertex at least as far from the VPL as its sparse point: no change (the old model).
    std::vector<ref::VplPair> far;
    ref::interpolateVerticesInto(std::vector<dvec3>{dvec3(0.09, 0, 0)}, std::vector<dvec3>{normals[0]},
                                 std::vector<List>{List{0, 0, 0, 0, 0, 0, 0, 0}}, sparse, vpls, far);
    EXPECT_EQ(far[0].diffuse.r2, 0.0);
}

// G10: one sparse point x at the origin facing +z, one VAL 1 m away, 2 cm above its
// plane, facing it: x sees the light at cos_x = 0.02, so eq. 11 divides by 0.02. A vertex at x whose
// normal is tilted 60 deg toward the light shades L'' cos_v / D = E cos_v / cos_x ~ 43 E without the
// cap; with it, at most the peak channel of what x gathered (colour kept). At x's own normal eq. 10
// reproduces E (eq. 11), so there the cap does not bind. E is eq. 3-4's closed form for one disc,
// written here: M r^2 cos_l cos_i / (r^2 + d^2) per channel, M = flux / area.
TEST(GatherReference, VertexIrradianceCapBoundsTheShadedLightByTheGatheredPeak) {
    const dvec3 l(1.0, 0.0, 0.02);
    const double area = 1e-4, d2 = glm::dot(l, l), r2 = area / std::numbers::pi;
    const dvec3 flux(1.0, 2.0, 3.0);
    const double cosL = 1.0 / std::sqrt(d2), cosI = 0.02 / std::sqrt(d2); // normal (-1, 0, 0); x's normal +z
    const dvec3 e = flux / area * (r2 * cosL * cosI / (r2 + d2));
    std::vector<ref::Receiver> sparse(1);
    std::vector<ref::GatherSums> sums;
    ref::gatherInto(std::vector<gi::VirtualAreaLight>{disc(glm::vec3(l), {-1, 0, 0}, float(area), glm::vec3(flux))},
                    sparse, dvec3(0, 0, 5), ref::GatherParameters{}, sums);
    std::vector<ref::VplPair> vpls;
    ref::renormaliseInto(sums, sparse, dvec3(0, 0, 5), vpls);
    // float inputs (the VAL's position, area and flux are floats): 1e-6 relative
    EXPECT_NEAR(vpls[0].diffuseCap, e.z, 1e-6 * e.z) << "the sparse point's cap input is its gathered peak";
    using List = std::array<std::uint32_t, 8>;
    const dvec3 tilted(std::sin(std::numbers::pi / 3.0), 0.0, 0.5);
    const std::vector<dvec3> positions{dvec3(0.0), dvec3(0.0)};
    const std::vector<dvec3> normals{tilted, dvec3(0, 0, 1)};
    const std::vector<List> neighbours{List{}, List{}};
    std::vector<ref::VplPair> capped, uncapped;
    ref::interpolateVerticesInto(positions, normals, neighbours, sparse, vpls, capped, true);
    ref::interpolateVerticesInto(positions, normals, neighbours, sparse, vpls, uncapped, false);
    EXPECT_DOUBLE_EQ(capped[0].diffuseCap, vpls[0].diffuseCap);
    EXPECT_LT(uncapped[0].diffuseCap, 0.0);
    // rho_d = pi: shade() returns the irradiance itself
    const auto irradianceAt = [](const ref::VplPair& v, const dvec3& n) {
        return ref::shade(v, ref::Surface{dvec3(0.0), n, dvec3(std::numbers::pi), dvec3(0.0), 1.0}, dvec3(0, 0, 5));
    };
    const dvec3 amplified = irradianceAt(uncapped[0], tilted);
    EXPECT_GT(amplified.z, 10.0 * e.z) << "without the cap, renormalisation amplifies (cos_v / cos_x ~ 43)";
    const dvec3 bounded = irradianceAt(capped[0], tilted);
    EXPECT_NEAR(bounded.z, e.z, 1e-6 * e.z) << "capped at the gathered peak";
    EXPECT_NEAR(bounded.x / bounded.z, 1.0 / 3.0, 1e-12) << "colour kept";
    // At the sparse point's own normal eq. 10 reproduces E: the cap does not bind (G4 not reached).
    const dvec3 own = irradianceAt(capped[1], dvec3(0, 0, 1));
    EXPECT_NEAR(own.x, e.x, 1e-6 * e.x);
    EXPECT_NEAR(own.z, e.z, 1e-6 * e.z);
    // The occluded share o scales the cap like the light.
    ref::applyOcclusion(std::vector<glm::dvec2>{glm::dvec2(0.25, 0.0)}, vpls);
    EXPECT_NEAR(vpls[0].diffuseCap, 0.75 * e.z, 1e-6 * e.z);
}

// Numerical extremes on the reference: finite, non-negative, bounded by sum M_j, guards exact.
struct Extreme {
    const char* name;
    std::vector<gi::VirtualAreaLight> vals;
    dvec3 x{0.0};
    dvec3 n{0, 0, 1};
    double k = 20.0;
    bool expectZero = false;
};

std::vector<Extreme> extremes() {
    std::vector<Extreme> cases;
    cases.push_back({"no VAL", {}, dvec3(0.0), dvec3(0, 0, 1), 20.0, true});
    cases.push_back(
        {"coincident", {disc({0, 0, 0}, {0, 0, -1}, 1e-4f, {1, 1, 1})}, dvec3(0.0), dvec3(0, 0, 1), 20.0, true});
    cases.push_back({"1e-6 apart", {disc({0, 0, 1e-6f}, {0, 0, -1}, 1e-4f, {1, 1, 1})}});
    for (float scale : {1e-3f, 1e3f}) {
        Extreme e{scale < 1 ? "scale 1e-3" : "scale 1e3", {}, dvec3(scale), dvec3(0, 0, 1)};
        e.vals = squareEmitter(glm::vec3(scale) + glm::vec3(0, 0, 0.5f * scale), {0, 0.2f, -1}, scale, 8, {1, 1, 1});
        cases.push_back(e);
    }
    cases.push_back({"grazing above", {disc({1, 0, 1e-4f}, {-1, 0, 0}, 1e-2f, {1, 1, 1})}});
    cases.push_back({"grazing below",
                     {disc({1, 0, -1e-4f}, {-1, 0, 0}, 1e-2f, {1, 1, 1})},
                     dvec3(0.0),
                     dvec3(0, 0, 1),
                     20.0,
                     true});
    cases.push_back(
        {"back-facing", {disc({0, 0, 1}, {0, 0, 1}, 1e-2f, {1, 1, 1})}, dvec3(0.0), dvec3(0, 0, 1), 20.0, true});
    for (double k : {1.0, 100.0, 1e4}) {
        Extreme e{"exponent",
                  {disc({0, 0.01f, 1}, {0, 0, -1}, 1e-2f, {1, 1, 1}), disc({1, 0, 1}, {-1, 0, -1}, 1e-2f, {1, 1, 1})}};
        e.k = k;
        cases.push_back(e);
    }
    cases.push_back({"single VAL", {disc({0.3f, 0.2f, 1}, {0, 0, -1}, 1e-2f, {1, 2, 3})}});
    {
        Extreme e{"all at one point", {}};
        for (int i = 0; i < 1000; ++i) e.vals.push_back(disc({0.2f, 0, 1}, {0, 0, -1}, 1e-3f, {1, 1, 1}));
        cases.push_back(e);
    }
    {
        // whole discs below the horizon: radius sqrt(1e-4 / pi) = 5.6 mm < the 1 cm depth of the nearest
        // centre (a larger disc reaches above the horizon, and guard G12 rightly lights the receiver)
        Extreme e{"all below the horizon", randomVals(500, {-1, -1, -2}, {1, 1, -0.01f}, {0, 0, 0}, 1e-4f, 3)};
        e.expectZero = true;
        cases.push_back(e);
    }
    return cases;
}

TEST(GatherReference, NumericalExtremesStayFiniteNonNegativeAndBounded) {
    const dvec3 eye(0.5, 0.3, 2.0);
    for (const Extreme& c : extremes()) {
        SCOPED_TRACE(c.name);
        ref::Receiver r;
        r.position = c.x;
        r.normal = c.n;
        r.exponent = c.k;
        std::vector<ref::GatherSums> sums;
        ref::gatherInto(c.vals, std::span(&r, 1), eye, {}, sums);
        std::vector<ref::VplPair> vpls;
        ref::renormaliseInto(sums, std::span(&r, 1), eye, vpls);
        // per channel: E = sum_j M_j w_j cos(theta_i) <= sum_j M_j, since w_j cos(theta_i) <= 1
        // (eq. 3: r^2 cos / (r^2 + d^2) <= 1); the glossy sum likewise <= c_k sum_j M_j
        dvec3 bound(0.0);
        for (const auto& l : c.vals) bound += dvec3(l.flux) / double(l.area);
        const ref::Surface s{c.x, c.n, dvec3(1.0), dvec3(1.0), c.k};
        const dvec3 shaded = ref::shade(vpls[0], s, eye);
        const double ck = (c.k + 1.0) / (2.0 * kPi);
        for (int ch = 0; ch < 3; ++ch) {
            EXPECT_TRUE(std::isfinite(sums[0].irradiance[ch]) && std::isfinite(sums[0].glossy[ch]));
            EXPECT_TRUE(std::isfinite(vpls[0].diffuse.radiance[ch]) && std::isfinite(vpls[0].glossy.radiance[ch]));
            EXPECT_TRUE(std::isfinite(shaded[ch]));
            EXPECT_GE(sums[0].irradiance[ch], 0.0);
            EXPECT_GE(sums[0].glossy[ch], 0.0);
            EXPECT_GE(shaded[ch], 0.0);
            EXPECT_LE(sums[0].irradiance[ch], bound[ch] * (1.0 + 1e-12) + 1e-300);
            EXPECT_LE(sums[0].glossy[ch], ck * bound[ch] * (1.0 + 1e-12) + 1e-300);
            EXPECT_LE(shaded[ch], (1.0 / kPi + ck) * bound[ch] * (1.0 + 1e-12) + 1e-300)
                << "eq. 10 at the point reproduces eq. 8 or less";
            if (!c.expectZero) {
                EXPECT_GT(sums[0].irradiance[ch], 0.0) << "a lit case must not pass with zero output";
            }
            if (c.expectZero) {
                EXPECT_EQ(sums[0].irradiance[ch], 0.0);
                EXPECT_EQ(sums[0].glossy[ch], 0.0);
                EXPECT_EQ(shaded[ch], 0.0);
            }
        }
        EXPECT_TRUE(std::isfinite(vpls[0].diffuse.position.x) && std::isfinite(vpls[0].glossy.position.z));
    }
}

TEST(GatherReference, GlossyLobeUnderflowIsExactlyZeroNotDenormal) {
    // cos(gamma) = 0.5 at k = 1e4: 0.5^1e4 underflows any float; the guard returns exactly 0.
    const auto l = disc({1, 0, 1}, {-1, 0, -1}, 1e-2f, {1, 1, 1});
    ref::Receiver r;
    r.exponent = 1e4;
    std::vector<ref::GatherSums> sums;
    ref::gatherInto(std::span(&l, 1), std::span(&r, 1), dvec3(0, 0, 5), {}, sums);
    EXPECT_EQ(sums[0].glossy.x, 0.0);
    EXPECT_GT(sums[0].irradiance.x, 0.0);
}

} // namespace
} // namespace lightskin::test
