// Independent references for every equation of the GI core: closed forms for
// eq. 5, 7, 11, 12-13 and 14, each checked on the independent implementation (PaperReference.h)
// AND on the shared-math double reference (gi::reference, compiled from lightskin_math.glsl);
// then the two implementations stage by stage on a sphere over a floor. A formula error in
// lightskin_math.glsl changes gi::reference and the shaders alike, but not PaperReference: it
// fails here (and in the GL tests, which compare the GPU with PaperReference too).
#include "PaperReference.h"

#include "common/GatherTestScenes.h"

#include <lightskin/gi/reference/LightSkinReference.h>
#include <lightskin/gi/common/SparsePointSampler.h>

#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>

namespace lightskin::test {
namespace {

namespace ref = gi::reference;
using glm::dvec3;
constexpr double kPi = std::numbers::pi;
// Closed forms are evaluated in double from float VAL data (positions and areas exact in float
// for the values used): both implementations agree with them to rounding, ~1e-15 relative; 1e-12
// leaves room for the ~10 operations per value and is still 1e9 times below any formula error.
constexpr double kExact = 1e-12;

paper::Point point(const dvec3& p, const dvec3& n, double k = 1.0, double occluderRadius = 0.0) {
    return {p, glm::normalize(n), k, occluderRadius};
}
ref::Receiver receiver(const paper::Point& p) { return {p.position, p.normal, p.exponent, p.occluderRadius}; }

struct Both {
    paper::PointGather paper;
    ref::GatherSums shared;
};
Both gatherBoth(std::span<const gi::VirtualAreaLight> vals, const paper::Point& x, const dvec3& eye) {
    Both b;
    b.paper = paper::gather(vals, x, eye, {});
    std::vector<ref::GatherSums> sums;
    const ref::Receiver r = receiver(x);
    ref::gatherInto(vals, std::span(&r, 1), eye, {}, sums);
    b.shared = sums[0];
    return b;
}

// eq. 5: one disc straight above the receiver. Coaxial, so w = r^2 / (r^2 + h^2) exactly (eq. 3)
// and cos(theta_i) = 1; the viewer on the mirror direction gives cos(gamma) = 1, a viewer
// alpha off it cos(gamma) = cos(alpha). L'_s = c (k + 1) M w cos^k(alpha), W_s = eps + w cos^k.
TEST(PaperReference, GlossyTermOfOneCoaxialDiscIsTheClosedForm) {
    const double h = 0.8, area = 0.05, flux = 0.2, k = 20.0;
    const auto val = disc({0, 0, float(h)}, {0, 0, -1}, float(area), glm::vec3(float(flux)));
    // the VAL stores floats: the closed form uses the same rounded h, area and flux
    const double hf = double(val.position.z), af = double(val.area), ff = double(val.flux.x);
    const double r2 = af / kPi, w = r2 / (r2 + hf * hf), m = ff / af, c = 1.0 / (2.0 * kPi);
    for (double alpha : {0.0, 0.2, 0.5}) {
        SCOPED_TRACE(alpha);
        const dvec3 eye = 3.0 * dvec3(std::sin(alpha), 0.0, std::cos(alpha));
        const Both b = gatherBoth(std::span(&val, 1), point(dvec3(0.0), {0, 0, 1}, k), eye);
        const double lobe = std::pow(std::cos(alpha), k);
        const double expected = c * (k + 1.0) * m * w * lobe;
        ASSERT_GT(expected, 1e-3 * c * (k + 1.0) * m * w) << "non-trivial lobe";
        EXPECT_NEAR(b.paper.glossy.sum.x, expected, kExact * expected);
        EXPECT_NEAR(b.shared.glossy.x, expected, kExact * expected);
        EXPECT_NEAR(b.shared.weightS, 1e-20 + w * lobe, kExact * w * lobe);
        EXPECT_NEAR(b.paper.diffuse.sum.x, m * w, kExact * m * w) << "eq. 4: E = M w cos(theta_i)";
        EXPECT_NEAR(b.shared.irradiance.x, m * w, kExact * m * w);
    }
}

// eq. 7 and 11 on two equal discs at (+-a, 0, h) facing down, receiver at the origin facing up,
// eye straight above. d^2 = a^2 + h^2, cos(theta_i) = cos(theta_j) = h / d, so
// w = r^2 (h/d) / (r^2 + d^2); cos(gamma) = h / d (mirror of (a, 0, h)/d is (-a, 0, h)/d).
//   L'_d = 2 M w h/d, W_d = 2 (eps + w h/d), l'_d = (0, 0, h), rbar^2 = r^2, sigma_x = a (S_o radius a)
//   L'_s = 2 c (k+1) M w (h/d)^k, l'_s = (0, 0, h), S_o radius sqrt(a^2 / 3) (isotropic, trace / 3)
//   eq. 11: l' is straight above, cos(theta) = cos(gamma) = 1, D = h^2 + r^2, so L'' = L' (h^2 + r^2).
TEST(PaperReference, AveragedAndRenormalisedVplsOfTwoSymmetricDiscsAreTheClosedForm) {
    const double a = 0.3, h = 0.7, area = 0.02, flux = 0.1, k = 8.0, c = 1.0 / (2.0 * kPi);
    const std::vector<gi::VirtualAreaLight> vals = {
        disc({float(a), 0, float(h)}, {0, 0, -1}, float(area), glm::vec3(float(flux))),
        disc({float(-a), 0, float(h)}, {0, 0, -1}, float(area), glm::vec3(float(flux)))};
    const double ah = double(float(a)), hh = double(float(h)), ar = double(float(area)), fl = double(float(flux));
    const double r2 = ar / kPi, d2 = ah * ah + hh * hh, cosine = hh / std::sqrt(d2), m = fl / ar;
    const double w = r2 * cosine / (r2 + d2);
    const double diffuse = 2.0 * m * w * cosine, glossy = 2.0 * c * (k + 1.0) * m * w * std::pow(cosine, k);
    const dvec3 eye(0.0, 0.0, 4.0);
    const paper::Point x = point(dvec3(0.0), {0, 0, 1}, k);
    const Both b = gatherBoth(vals, x, eye);
    EXPECT_NEAR(b.paper.diffuse.sum.x, diffuse, kExact * diffuse);
    EXPECT_NEAR(b.shared.irradiance.x, diffuse, kExact * diffuse);
    EXPECT_NEAR(b.paper.glossy.sum.x, glossy, kExact * glossy);
    EXPECT_NEAR(b.shared.glossy.x, glossy, kExact * glossy);
    EXPECT_NEAR(b.shared.weightD, 2.0 * w * cosine, kExact * w);
    EXPECT_NEAR(b.shared.r2D / b.shared.weightD, r2, kExact * r2) << "rbar^2";
    EXPECT_NEAR(b.shared.offsetD.z / b.shared.weightD, hh, kExact) << "l'_d";
    EXPECT_NEAR(b.shared.offsetD.x / b.shared.weightD, 0.0, kExact);

    std::vector<ref::VplPair> shared;
    const ref::Receiver rx = receiver(x);
    ref::renormaliseInto(std::span(&b.shared, 1), std::span(&rx, 1), eye, shared);
    const paper::LightPair mine = paper::renormalise(b.paper, x, eye, {});
    const double distance2 = hh * hh + r2;
    EXPECT_NEAR(mine.diffuse.radiance.x, diffuse * distance2, kExact * diffuse * distance2);
    EXPECT_NEAR(mine.diffuse.sphereRadius, ah, kExact);
    EXPECT_NEAR(shared[0].diffuse.radiance.x, diffuse * distance2, kExact * diffuse * distance2);
    EXPECT_NEAR(shared[0].glossy.radiance.x, glossy * distance2, kExact * glossy * distance2);
    EXPECT_NEAR(mine.glossy.radiance.x, glossy * distance2, kExact * glossy * distance2);
    EXPECT_NEAR(shared[0].diffuse.r2, r2, kExact * r2);
    EXPECT_NEAR(shared[0].glossy.r2, r2, kExact * r2);
    EXPECT_NEAR(shared[0].diffuse.position.z, hh, kExact);
    EXPECT_NEAR(shared[0].glossy.position.z, hh, kExact);
    EXPECT_NEAR(shared[0].diffuse.sphereRadius, ah, 1e-9) << "S_o radius = max sigma (sqrt of a difference)";
    EXPECT_NEAR(shared[0].glossy.sphereRadius, ah / std::sqrt(3.0), 1e-9);
    EXPECT_NEAR(mine.glossy.sphereRadius, ah / std::sqrt(3.0), kExact);
}

// eq. 12-13 by hand: 8 neighbours at distances 1..8 on the x axis, all normals +z except the
// third (cos = 0.5). w_j = (1 - d_j / 8) cos_j = (14, 12, 5, 8, 6, 4, 2, 0) / 16, W_v = 51/16.
// With L''_j = j + 1 and l''_j = (j, 0, 1): L''' = 153 / 51 = 3, l'''.x = 102 / 51 = 2.
// Guard G9: eq. 10 of gi::reference (the shaders' closed form, Snyder's sphere
// irradiance clipped by the horizon) against the independent quadrature of its definition
// (paper::horizonFactor: projected solid angle of a cone / pi sin^2 sigma), for a VPL of spread R at
// distance d swept from above to below the receiver's horizon. Tolerance: the quadrature's relative
// error is ~1e-7 (4096 midpoint steps of a function with a bounded second derivative) and the
// closed form is double arithmetic: 1e-6 of the unclipped value. Above the horizon by more than
// sigma the factor must be cos(theta) exactly (no change to the paper's model there), below it by
// more than sigma exactly 0, and in between strictly positive: no receiver with light partly
// above its horizon gets 0 (the black pixels seen on real depth).
TEST(PaperReference, ExtendedVplHorizonFactorIsTheClippedConeIntegral) {
    const double d = 0.8;
    for (const double R : {0.002, 0.05, 0.3, 0.8, 3.0}) {
        const double sin2 = R * R / (R * R + d * d), sinSigma = std::sqrt(sin2);
        double previous = -1.0;
        for (int i = 0; i <= 200; ++i) {
            const double theta = kPi * double(i) / 200.0; // 0 .. pi from the normal
            ref::VplPair v{};
            v.diffuse.radiance = dvec3(d * d);
            v.diffuse.position = d * dvec3(std::sin(theta), 0.0, std::cos(theta));
            v.diffuse.sphereRadius = R;
            const ref::Surface surface{dvec3(0.0), {0, 0, 1}, dvec3(kPi), dvec3(0.0), 1.0};
            const double shared = ref::shade(v, surface, {0, 0, 5}).x; // = L'' h / D * rho / pi = h
            const double quadrature = paper::horizonFactor(std::cos(theta), sin2);
            SCOPED_TRACE("R " + std::to_string(R) + ", theta " + std::to_string(theta));
            EXPECT_NEAR(shared, quadrature, 1e-6);
            if (std::cos(theta) >= sinSigma + 1e-9) {
                EXPECT_NEAR(shared, std::cos(theta), 1e-12);
            }
            if (std::cos(theta) <= -sinSigma - 1e-9) {
                EXPECT_EQ(shared, 0.0);
            }
            if (std::abs(std::cos(theta)) < sinSigma - 1e-6 && sin2 > 1e-6) {
                EXPECT_GT(shared, 0.0);
            }
            if (previous >= 0.0) {
                EXPECT_LE(shared, previous + 1e-12); // falls monotonically with theta
            }
            previous = shared;
        }
    }
}

TEST(PaperReference, VertexWeightsOfEightNeighboursAreTheHandComputedValues) {
    std::vector<paper::Point> points;
    std::vector<ref::Receiver> receivers;
    std::vector<ref::VplPair> shared(8);
    std::vector<paper::LightPair> mine(8);
    for (int j = 0; j < 8; ++j) {
        const dvec3 n = j == 2 ? dvec3(std::sqrt(0.75), 0.0, 0.5) : dvec3(0, 0, 1);
        points.push_back(point(dvec3(j + 1, 0, 0), n));
        receivers.push_back(receiver(points.back()));
        shared[std::size_t(j)].diffuse.radiance = shared[std::size_t(j)].glossy.radiance = dvec3(j + 1);
        shared[std::size_t(j)].diffuse.position = shared[std::size_t(j)].glossy.position = dvec3(j, 0, 1);
        shared[std::size_t(j)].diffuse.r2 = shared[std::size_t(j)].glossy.r2 = 0.01 * (j + 1);
        mine[std::size_t(j)].diffuse = {dvec3(j + 1), dvec3(j, 0, 1), 0.01 * (j + 1), 0.0};
        mine[std::size_t(j)].glossy = mine[std::size_t(j)].diffuse;
    }
    const std::array<std::uint32_t, 8> list{0, 1, 2, 3, 4, 5, 6, 7};
    const auto w = paper::vertexWeights(dvec3(0.0), {0, 0, 1}, list, points);
    const double expected[8] = {14, 12, 5, 8, 6, 4, 2, 0};
    for (int j = 0; j < 8; ++j) EXPECT_NEAR(w[std::size_t(j)], expected[j] / 51.0, kExact) << j;
    std::vector<ref::VplPair> out;
    ref::interpolateVerticesInto(std::vector<dvec3>{dvec3(0.0)}, std::vector<dvec3>{dvec3(0, 0, 1)},
                                 std::vector<std::array<std::uint32_t, 8>>{list}, receivers, shared, out);
    const paper::LightPair p = paper::interpolate(dvec3(0.0), {0, 0, 1}, list, points, mine);
    const double r2 = 0.01 * (14 * 1 + 12 * 2 + 5 * 3 + 8 * 4 + 6 * 5 + 4 * 6 + 2 * 7) / 51.0;
    for (const auto& [radiance, position, meanR2] :
         {std::tuple{out[0].diffuse.radiance.x, out[0].diffuse.position.x, out[0].diffuse.r2},
          std::tuple{out[0].glossy.radiance.x, out[0].glossy.position.x, out[0].glossy.r2},
          std::tuple{p.diffuse.radiance.x, p.diffuse.position.x, p.diffuse.r2},
          std::tuple{p.glossy.radiance.x, p.glossy.position.x, p.glossy.r2}}) {
        EXPECT_NEAR(radiance, 3.0, kExact);
        EXPECT_NEAR(position, 2.0, kExact);
        EXPECT_NEAR(meanR2, r2, kExact);
    }
}

// eq. 14 / section 3.3 with one coaxial occluder disc between the point and S_o. Both project
// (Nusselt) to concentric circles on the unit circle of areas pi F, F = r^2 / (r^2 + d^2) (eq. 3
// with cos = 1): the exact hidden fraction of a disc-shaped S_o is min(1, F_occ / F_S). The
// paper's quads of equal areas are concentric too, so the model is exact here. Occluders inside
// S_o count linearly less (the core's documented depth factor clamp((D - d_occ) / R, 0, 1)).
// Off axis, the quads' overlap is a product of two interval overlaps (computed by hand below).
TEST(PaperReference, OneCoaxialOccluderDiscHidesTheAnalyticFraction) {
    const double distance = 2.0, radius = 0.4; // S_o at (0, 0, 2), radius 0.4
    const double targetF = radius * radius / (radius * radius + distance * distance);
    struct Case {
        const char* name;
        dvec3 position;
        dvec3 normal;
        double radius;
        double expected;
    };
    const auto f = [](double r, double d) { return r * r / (r * r + d * d); };
    const double small = 0.07, tilt = 0.6; // occluder radius (F_occ / F_S = 0.5), tilt angle (rad)
    const double lateral = 0.1;            // off-axis shift of the occluder at height 0.5
    // off axis: projected centre u = (lateral, 0, 0.5) / |.|, occluder side s_o = sqrt(pi F cos_i),
    // target side s_t = sqrt(pi targetF); overlap x = (s_t + s_o) / 2 - |u_x| (partial), y = s_o
    const double dOff = std::sqrt(lateral * lateral + 0.25), cosOff = 0.5 / dOff;
    const double sideOff = std::sqrt(kPi * small * small * cosOff / (small * small + dOff * dOff) * cosOff);
    const double sideTarget = std::sqrt(kPi * targetF);
    const double overlapX = std::min(0.5 * (sideTarget + sideOff) - lateral / dOff, sideOff);
    const std::vector<Case> cases = {
        {"small, in front", {0, 0, 0.5}, {0, 0, -1}, small, f(small, 0.5) / targetF},
        {"facing away counts the same (|n . u|)", {0, 0, 0.5}, {0, 0, 1}, small, f(small, 0.5) / targetF},
        {"large: all hidden", {0, 0, 0.5}, {0, 0, -1}, 0.3, 1.0},
        {"tilted: area times cos",
         {0, 0, 0.5},
         {std::sin(tilt), 0, -std::cos(tilt)},
         small,
         small * small * std::cos(tilt) / (small * small + 0.25) / targetF},
        {"halfway into S_o",
         {0, 0, distance - 0.5 * radius},
         {0, 0, -1},
         0.05,
         0.5 * f(0.05, distance - 0.5 * radius) / targetF},
        {"behind the centre of S_o", {0, 0, distance + 0.1}, {0, 0, -1}, 0.3, 0.0},
        {"below the horizon", {0, 0, -0.5}, {0, 0, 1}, 0.3, 0.0},
        {"far to the side", {3.0, 0, 0.5}, {0, 0, -1}, small, 0.0},
        {"partly overlapping", {lateral, 0, 0.5}, {0, 0, -1}, small, overlapX * sideOff / (sideTarget * sideTarget)},
    };
    ASSERT_GT(overlapX, 0.0);
    ASSERT_LT(overlapX, sideOff) << "the off-axis case must overlap only partly";
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        ASSERT_LE(c.expected, 1.0);
        const std::vector<paper::Point> points = {point(dvec3(0.0), {0, 0, 1}),
                                                  point(c.position, c.normal, 1.0, c.radius)};
        std::vector<paper::LightPair> lights(2);
        lights[0].diffuse = lights[0].glossy = {dvec3(1.0), dvec3(0, 0, distance), 0.0, radius};
        const glm::dvec2 mine = paper::occlusion(points, lights, 0);
        EXPECT_NEAR(mine.x, c.expected, kExact);
        EXPECT_NEAR(mine.y, c.expected, kExact);
        const std::vector<ref::Receiver> receivers = {receiver(points[0]), receiver(points[1])};
        std::vector<ref::VplPair> vpls(2);
        vpls[0].diffuse = vpls[0].glossy = {dvec3(1.0), 0.0, dvec3(0, 0, distance), radius};
        std::vector<glm::dvec2> shared;
        ref::occlusionInto(receivers, vpls, shared);
        EXPECT_NEAR(shared[0].x, c.expected, kExact);
        EXPECT_NEAR(shared[0].y, c.expected, kExact);
    }
}

// The two implementations stage by stage on a sphere over a floor (production sparse points,
// ~1000 random VALs, glossy, occlusion). Both are double; they differ in summation order and
// formulation (absolute vs relative positions, two-pass variances): ~1e-13 relative for sums of
// 10^3 positive terms; eq. 11 divides by cos(theta) down to the 1e-3 floor, amplifying position
// rounding (1e-16 m) 1e3 times, and S_o radii are square roots of differences of moments
// (cancellation ~1e-16 |l - x|^2 / sigma^2). Hence 1e-8 relative, with a floor of 1e-10 of the
// stage's largest value for signed or cancelling quantities; any formula error is >= 1e-3.
class Stage {
public:
    explicit Stage(const char* name)
        : name_(name) {}
    /// `absolute`: an extra allowance for values computed with cancellation (see the caller).
    void add(double shared, double independent, double absolute = 0.0) {
        pairs_.push_back({shared, independent, absolute});
    }
    void check() const {
        double largest = 0.0;
        for (const auto& p : pairs_) largest = std::max(largest, std::abs(p[1]));
        ASSERT_GT(largest, 0.0) << name_ << ": all zero, the scene does not exercise this stage";
        std::size_t bad = 0;
        for (const auto& [s, i, a] : pairs_)
            if (!(std::abs(s - i) <= 1e-8 * std::abs(i) + 1e-10 * largest + a)) ++bad;
        EXPECT_EQ(bad, 0u) << name_ << ": " << bad << " of " << pairs_.size() << " values differ";
    }

private:
    const char* name_;
    std::vector<std::array<double, 3>> pairs_;
};

TEST(PaperReference, SharedMathReferenceMatchesTheIndependentOneAtEveryStage) {
    gi::SparsePointSettings sampling;
    sampling.pointCount = 120;
    const TriangleMesh sphere = makeSphere(0.3f, 12, 24), floor = makeGrid(2.0f, 12);
    const glm::mat4 sphereTransform = glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 0.45f});
    const auto sphereSet = gi::sampleSparsePoints(sphere, sampling, "sphere");
    sampling.pointCount = 60;
    const auto floorSet = gi::sampleSparsePoints(floor, sampling, "floor");
    auto receivers = ref::receiversFromSparsePoints(sphereSet, sphereTransform, 20.0);
    const auto floorReceivers = ref::receiversFromSparsePoints(floorSet, glm::mat4(1.0f), 5.0);
    receivers.insert(receivers.end(), floorReceivers.begin(), floorReceivers.end());
    std::vector<paper::Point> points;
    for (const auto& r : receivers) points.push_back({r.position, r.normal, r.exponent, r.occluderRadius});

    auto vals = squareEmitter({-1.0f, 0.0f, 0.6f}, {1.0f, 0.0f, 0.0f}, 1.2f, 24, {1.0f, 0.8f, 0.6f});
    const auto extra = randomVals(424, {-1.5f, -1.5f, 1.0f}, {1.5f, 1.5f, 2.0f}, {0, 0, 0}, 0.005f, 11);
    vals.insert(vals.end(), extra.begin(), extra.end());
    const dvec3 eye(1.6, -1.8, 1.5);

    std::vector<ref::GatherSums> sums;
    std::vector<ref::VplPair> vpls;
    std::vector<glm::dvec2> occlusion;
    // The paper's point-like discs (eq. 3): guard G12 (near-field VALs as areas, a deviation from the
    // paper) is off here; the emitter touches the floor, so its near field holds floor receivers. G12
    // has its own independent references (GatherReferenceTest.cpp: Howell's closed forms, quadrature).
    ref::GatherParameters paperModel;
    paperModel.nearField = false;
    ref::gatherInto(vals, receivers, eye, paperModel, sums);
    ref::renormaliseInto(sums, receivers, eye, vpls);
    ref::occlusionInto(receivers, vpls, occlusion);
    const paper::Run mine = paper::run(vals, points, eye, {}, true);

    Stage gathered("eq. 7 sums"), averaged("eq. 7 l', rbar^2, S_o"), renormalised("eq. 11 L''"), occluded("eq. 14 o");
    for (std::size_t i = 0; i < points.size(); ++i) {
        const ref::GatherSums& s = sums[i];
        const paper::PointGather& g = mine.gathers[i];
        const dvec3 x = points[i].position;
        for (int c = 0; c < 3; ++c) {
            gathered.add(s.irradiance[c], g.diffuse.sum[c]);
            gathered.add(s.glossy[c], g.glossy.sum[c]);
            averaged.add(vpls[i].diffuse.position[c] - x[c], mine.lights[i].diffuse.position[c] - x[c]);
            averaged.add(vpls[i].glossy.position[c] - x[c], mine.lights[i].glossy.position[c] - x[c]);
            renormalised.add(vpls[i].diffuse.radiance[c], mine.lights[i].diffuse.radiance[c]);
            renormalised.add(vpls[i].glossy.radiance[c], mine.lights[i].glossy.radiance[c]);
        }
        gathered.add(s.weightD, g.diffuse.weight);
        gathered.add(s.weightS, g.glossy.weight);
        averaged.add(vpls[i].diffuse.r2, mine.lights[i].diffuse.r2);
        averaged.add(vpls[i].glossy.r2, mine.lights[i].glossy.r2);
        // S_o radius^2: the core takes E[(l - x)^2] - (l' - x)^2, which loses ~1e-16 |l' - x|^2
        // per axis to cancellation (x 10 for the accumulation); compared squared with that allowance
        const dvec3 offD = mine.lights[i].diffuse.position - x, offS = mine.lights[i].glossy.position - x;
        averaged.add(vpls[i].diffuse.sphereRadius * vpls[i].diffuse.sphereRadius,
                     mine.lights[i].diffuse.sphereRadius * mine.lights[i].diffuse.sphereRadius,
                     1e-15 * glm::dot(offD, offD));
        averaged.add(vpls[i].glossy.sphereRadius * vpls[i].glossy.sphereRadius,
                     mine.lights[i].glossy.sphereRadius * mine.lights[i].glossy.sphereRadius,
                     1e-15 * glm::dot(offS, offS));
        occluded.add(occlusion[i].x, mine.occlusion[i].x);
        occluded.add(occlusion[i].y, mine.occlusion[i].y);
    }
    gathered.check();
    averaged.check();
    renormalised.check();
    occluded.check();
    double maxOcclusion = 0.0;
    for (const auto& o : mine.occlusion) maxOcclusion = std::max(maxOcclusion, o.x);
    EXPECT_GT(maxOcclusion, 0.05) << "the floor under the sphere must be occluded";

    // eq. 12-13 and eq. 10 at the sphere's vertices (world space) from the occluded VPLs
    std::vector<ref::VplPair> occludedVpls = vpls;
    ref::applyOcclusion(occlusion, occludedVpls);
    std::vector<dvec3> positions, normals;
    std::vector<std::array<std::uint32_t, 8>> neighbours = sphereSet.vertexNeighbours;
    for (std::size_t v = 0; v < sphere.vertexCount(); ++v) {
        positions.push_back(dvec3(sphereTransform * glm::vec4(sphere.positions[v], 1.0f)));
        normals.push_back(dvec3(sphere.normals[v]));
    }
    std::vector<ref::VplPair> vertex;
    ref::interpolateVerticesInto(positions, normals, neighbours, receivers, occludedVpls, vertex);
    Stage interpolated("eq. 13 vertex VPLs"), shaded("eq. 10 radiance");
    for (std::size_t v = 0; v < positions.size(); ++v) {
        const paper::LightPair p = paper::interpolate(positions[v], normals[v], neighbours[v], points, mine.occluded);
        for (int c = 0; c < 3; ++c) {
            interpolated.add(vertex[v].diffuse.radiance[c], p.diffuse.radiance[c]);
            interpolated.add(vertex[v].glossy.radiance[c], p.glossy.radiance[c]);
            interpolated.add(vertex[v].diffuse.position[c], p.diffuse.position[c]);
            interpolated.add(vertex[v].glossy.position[c], p.glossy.position[c]);
        }
        interpolated.add(vertex[v].diffuse.r2, p.diffuse.r2);
        interpolated.add(vertex[v].glossy.r2, p.glossy.r2);
        const ref::Surface surface{positions[v], normals[v], dvec3(0.8, 0.7, 0.6), dvec3(0.3), 20.0};
        const dvec3 expected =
            paper::shade(p, positions[v], normals[v], eye, surface.diffuseAlbedo, surface.specular, 20.0);
        const dvec3 actual = ref::shade(vertex[v], surface, eye);
        for (int c = 0; c < 3; ++c) shaded.add(actual[c], expected[c]);
    }
    interpolated.check();
    shaded.check();
}

} // namespace
} // namespace lightskin::test
