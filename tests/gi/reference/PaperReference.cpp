// Independent implementation of the LightSkin equations (see PaperReference.h for what it follows
// and why it is written differently from gi/lightskin/shaders/lightskin_math.glsl).
#include "PaperReference.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace lightskin::test::paper {

namespace {
constexpr double kPi = std::numbers::pi;

glm::dvec3 unit(const glm::dvec3& v) {
    const double length = glm::length(v);
    return length > 0.0 ? v / length : glm::dvec3(0.0);
}

// cos^k for a cosine clamped at 0 (the Phong lobe has no negative part).
double lobePower(double cosine, double k) { return cosine > 0.0 ? std::pow(std::min(cosine, 1.0), k) : 0.0; }

// Orthonormal tangent frame (t, b, n) of Duff et al. 2017, "Building an Orthonormal Basis,
// Revisited", listing 3: the frame eq. 14 projects onto (the quads of 3.3 are aligned with it).
void frame(const glm::dvec3& n, glm::dvec3& t, glm::dvec3& b) {
    const double sign = n.z >= 0.0 ? 1.0 : -1.0;
    const double a = -1.0 / (sign + n.z);
    const double c = n.x * n.y * a;
    t = {1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x};
    b = {c, sign + n.y * n.y * a, -n.y};
}

// Length of the overlap of the intervals [c0 - s0/2, c0 + s0/2] and [c1 - s1/2, c1 + s1/2].
double overlap(double c0, double s0, double c1, double s1) {
    const double lo = std::max(c0 - 0.5 * s0, c1 - 0.5 * s1);
    const double hi = std::min(c0 + 0.5 * s0, c1 + 0.5 * s1);
    return std::max(hi - lo, 0.0);
}

// Weighted mean position, mean r^2 and per-axis variance of the VALs with weights `weights`.
Averaged average(std::span<const gi::VirtualAreaLight> vals, const std::vector<double>& weights,
                 const glm::dvec3& sum) {
    Averaged a;
    a.sum = sum;
    for (std::size_t j = 0; j < vals.size(); ++j) {
        a.weight += weights[j];
        a.position += weights[j] * glm::dvec3(vals[j].position);
        a.meanR2 += weights[j] * double(vals[j].area) / kPi;
    }
    if (!(a.weight > 0.0)) return Averaged{sum, 0.0, glm::dvec3(0.0), 0.0, glm::dvec3(0.0)};
    a.position /= a.weight;
    a.meanR2 /= a.weight;
    for (std::size_t j = 0; j < vals.size(); ++j) {
        const glm::dvec3 d = glm::dvec3(vals[j].position) - a.position;
        a.variance += weights[j] * d * d;
    }
    a.variance /= a.weight;
    return a;
}

// (L'', l', rbar^2) of eq. 11 for a channel whose lobe at direction `dir` is `lobe`.
Light renormalised(const Averaged& a, const Point& x, double lobe, double sphereRadius, const Options& options) {
    Light l;
    if (!(a.weight > 0.0)) { // no VAL at all: no light, l' at the point
        l.position = x.position;
        return l;
    }
    const glm::dvec3 v = a.position - x.position;
    l.position = a.position;
    l.r2 = a.meanR2;
    l.sphereRadius = sphereRadius;
    l.radiance = a.sum * ((glm::dot(v, v) + a.meanR2) / std::max(lobe, options.renormalisationFloor));
    return l;
}
} // namespace

double horizonFactor(double cosTheta, double sin2) {
    // the core's design choice: spreads below 1e-3 rad (sin^2 1e-6) are points (float rounding of S_o)
    if (!(sin2 > 1e-6)) return std::max(cosTheta, 0.0);
    // Cone around the axis a, n = cos(theta) a + sin(theta) u. A direction at polar angle t from a
    // and azimuth phi from u has n . w = cos(theta) cos(t) + sin(theta) sin(t) cos(phi) = A + B cos(phi);
    // the phi integral of max(A + B cos(phi), 0) is exact, t is integrated by the midpoint rule
    // (4096 steps: relative error ~1e-7, far below every tolerance this serves).
    const double c = std::clamp(cosTheta, -1.0, 1.0), s = std::sqrt(1.0 - c * c);
    // A cone wholly above the horizon: its projected solid angle is exactly pi sin^2 sigma cos(theta).
    if (c > 0.0 && c * c >= sin2) return c;
    const double sigma = std::asin(std::sqrt(std::min(sin2, 1.0)));
    constexpr int kSteps = 4096;
    const double dt = sigma / kSteps;
    double integral = 0.0;
    for (int i = 0; i < kSteps; ++i) {
        const double t = (i + 0.5) * dt;
        const double a = c * std::cos(t), b = s * std::sin(t);
        double ring = 0.0;
        if (a >= b)
            ring = 2.0 * kPi * a;
        else if (a > -b) {
            const double phi0 = std::acos(-a / b);
            ring = 2.0 * (a * phi0 + b * std::sin(phi0));
        }
        integral += ring * std::sin(t) * dt;
    }
    return integral / (kPi * sin2);
}

double discWeight(const gi::VirtualAreaLight& val, const glm::dvec3& x) {
    const double r2 = double(val.area) / kPi;
    const glm::dvec3 fromLight = x - glm::dvec3(val.position);
    const double d2 = glm::dot(fromLight, fromLight);
    const double cosJ = std::max(glm::dot(glm::dvec3(val.normal), unit(fromLight)), 0.0);
    return r2 * cosJ / (r2 + d2);
}

double cosGamma(const glm::dvec3& normal, const glm::dvec3& toLight, const glm::dvec3& toEye) {
    // reflect the view direction about n; the angle to the light equals the angle between the
    // light's mirror direction and the view (the core reflects the light instead)
    return glm::dot(glm::reflect(-toEye, normal), toLight);
}

PointGather gather(std::span<const gi::VirtualAreaLight> vals, const Point& x, const glm::dvec3& eye,
                   const Options& options) {
    std::vector<double> weightD(vals.size(), 0.0), weightS(vals.size(), 0.0);
    glm::dvec3 irradiance(0.0), glossy(0.0);
    const glm::dvec3 toEye = unit(eye - x.position);
    const double ck = options.c * (x.exponent + 1.0); // eq. 5: c_k = c (k + 1)
    for (std::size_t j = 0; j < vals.size(); ++j) {
        const gi::VirtualAreaLight& val = vals[j];
        if (!(val.area > 0.0f)) continue; // invalid VAL: not a light (no eps_l either)
        const glm::dvec3 toLight = unit(glm::dvec3(val.position) - x.position);
        const double w = discWeight(val, x.position); // eq. 3
        const double cosI = std::max(glm::dot(x.normal, toLight), 0.0);
        const glm::dvec3 exitance = glm::dvec3(val.flux) / double(val.area); // M_j ("phi_j")
        const double lobe = cosI > 0.0 ? lobePower(cosGamma(x.normal, toLight, toEye), x.exponent) : 0.0;
        irradiance += exitance * w * cosI;        // eq. 4, 7: L'_d
        weightD[j] = options.epsilonL + w * cosI; // eq. 7: W_d terms
        if (options.glossy) {
            glossy += ck * exitance * w * lobe;       // eq. 5, 7: L'_s
            weightS[j] = options.epsilonL + w * lobe; // eq. 7: W_s terms
        }
    }
    return {average(vals, weightD, irradiance), average(vals, weightS, glossy)};
}

LightPair renormalise(const PointGather& g, const Point& x, const glm::dvec3& eye, const Options& options) {
    const glm::dvec3 toEye = unit(eye - x.position);
    const glm::dvec3 dirD = unit(g.diffuse.position - x.position);
    const glm::dvec3 dirS = unit(g.glossy.position - x.position);
    const double cosTheta = glm::dot(x.normal, dirD);
    const double lobe = glm::dot(x.normal, dirS) > 0.0 ? lobePower(cosGamma(x.normal, dirS, toEye), x.exponent) : 0.0;
    const glm::dvec3 vd = g.diffuse.variance, vs = g.glossy.variance;
    LightPair out;
    const double radiusD = std::sqrt(std::max({vd.x, vd.y, vd.z}));
    const double distance2 = glm::dot(g.diffuse.position - x.position, g.diffuse.position - x.position);
    const double sin2 = options.extendedVplHorizon ? radiusD * radiusD / (radiusD * radiusD + distance2) : 0.0;
    out.diffuse = renormalised(g.diffuse, x, horizonFactor(cosTheta, sin2), radiusD, options);
    out.glossy = renormalised(g.glossy, x, lobe, std::sqrt((vs.x + vs.y + vs.z) / 3.0), options);
    return out;
}

glm::dvec2 occlusion(std::span<const Point> points, std::span<const LightPair> lights, std::size_t i) {
    const Point& x = points[i];
    glm::dvec3 t, b;
    frame(x.normal, t, b);
    glm::dvec2 result(0.0);
    for (int channel = 0; channel < 2; ++channel) {
        const Light& light = channel == 0 ? lights[i].diffuse : lights[i].glossy;
        const glm::dvec3 v = light.position - x.position;
        const double distance = glm::length(v);
        const glm::dvec3 u = unit(v);
        const double radius2 = light.sphereRadius * light.sphereRadius;
        // Nusselt: pi F_disk (eq. 3 with cos(theta_j) = 1) is S_o's area on the unit circle
        const double targetArea =
            distance > 0.0 ? kPi * radius2 / (radius2 + distance * distance) * std::max(glm::dot(x.normal, u), 0.0)
                           : 0.0;
        if (!(targetArea > 1e-30)) continue;
        const double targetSide = std::sqrt(targetArea);
        const glm::dvec2 targetCentre(glm::dot(u, t), glm::dot(u, b)); // eq. 14
        double sum = 0.0;
        for (std::size_t j = 0; j < points.size(); ++j) {
            const Point& y = points[j];
            const glm::dvec3 q = y.position - x.position;
            const double dy = glm::length(q);
            if (j == i || !(dy > 0.0)) continue;
            const glm::dvec3 e = q / dy;
            const double cosI = glm::dot(x.normal, e);
            if (!(cosI > 0.0)) continue; // below the horizon
            const double ry2 = y.occluderRadius * y.occluderRadius;
            const double area = kPi * ry2 * std::abs(glm::dot(y.normal, e)) / (ry2 + dy * dy) * cosI; // pi F_disk
            const double side = std::sqrt(area);
            const glm::dvec2 centre(glm::dot(e, t), glm::dot(e, b)); // eq. 14
            const double shared = overlap(targetCentre.x, targetSide, centre.x, side) *
                                  overlap(targetCentre.y, targetSide, centre.y, side);
            const double depth = std::clamp((distance - dy) / std::max(light.sphereRadius, 1e-30), 0.0, 1.0);
            sum += shared / targetArea * depth;
        }
        result[channel] = std::clamp(sum, 0.0, 1.0);
    }
    return result;
}

std::array<double, gi::kVertexNeighbours>
vertexWeights(const glm::dvec3& vertex, const glm::dvec3& vertexNormal,
              const std::array<std::uint32_t, gi::kVertexNeighbours>& neighbours, std::span<const Point> points) {
    constexpr std::size_t n = gi::kVertexNeighbours;
    std::array<bool, n> repeat{};
    std::array<double, n> distance{}, cosine{}, w{};
    double dMax = 0.0;
    for (std::size_t j = 0; j < n; ++j) {
        for (std::size_t i = 0; i < j; ++i) repeat[j] = repeat[j] || neighbours[i] == neighbours[j];
        distance[j] = glm::distance(vertex, points[neighbours[j]].position);
        cosine[j] = std::clamp(glm::dot(vertexNormal, points[neighbours[j]].normal), 0.0, 1.0); // "clamped to [0,1]"
        if (!repeat[j]) dMax = std::max(dMax, distance[j]);
    }
    double total = 0.0;
    for (std::size_t j = 0; j < n; ++j) {
        w[j] = repeat[j] ? 0.0 : (dMax > 0.0 ? 1.0 - distance[j] / dMax : 1.0) * cosine[j]; // eq. 12
        total += w[j];
    }
    if (total <= 0.0) { // core guard G6a: every distance term vanished, normals alone
        total = 0.0;
        for (std::size_t j = 0; j < n; ++j) total += (w[j] = repeat[j] ? 0.0 : cosine[j]);
    }
    if (total <= 0.0) { // core guard G6b: the nearest neighbour alone
        w.fill(0.0);
        w[0] = total = 1.0;
    }
    for (double& weight : w) weight /= total; // eq. 13: 1 / W_v
    return w;
}

static double sq(const glm::dvec3& v) { return glm::dot(v, v); }

LightPair interpolate(const glm::dvec3& vertex, const glm::dvec3& vertexNormal,
                      const std::array<std::uint32_t, gi::kVertexNeighbours>& neighbours, std::span<const Point> points,
                      std::span<const LightPair> lights, bool distanceFloor) {
    const auto w = vertexWeights(vertex, vertexNormal, neighbours, points);
    LightPair out;
    // G8: the smallest D = |x_j - l_j|^2 + rbar_j^2 among the contributing points (weight > 0).
    double nearestD = std::numeric_limits<double>::infinity(), nearestS = nearestD;
    for (std::size_t j = 0; j < w.size(); ++j) {
        if (w[j] <= 0.0) continue;
        const LightPair& s = lights[neighbours[j]];
        const glm::dvec3 x = points[neighbours[j]].position;
        nearestD = std::min(nearestD, sq(s.diffuse.position - x) + s.diffuse.r2);
        nearestS = std::min(nearestS, sq(s.glossy.position - x) + s.glossy.r2);
    }
    for (std::size_t j = 0; j < w.size(); ++j) {
        const LightPair& s = lights[neighbours[j]];
        out.diffuse.radiance += w[j] * s.diffuse.radiance;
        out.diffuse.position += w[j] * s.diffuse.position;
        out.diffuse.r2 += w[j] * s.diffuse.r2;
        out.diffuse.sphereRadius += w[j] * s.diffuse.sphereRadius;
        out.glossy.radiance += w[j] * s.glossy.radiance;
        out.glossy.position += w[j] * s.glossy.position;
        out.glossy.r2 += w[j] * s.glossy.r2;
    }
    if (distanceFloor) {
        const double shortD = nearestD - (sq(out.diffuse.position - vertex) + out.diffuse.r2);
        const double shortS = nearestS - (sq(out.glossy.position - vertex) + out.glossy.r2);
        if (shortD > 0.0 && std::isfinite(shortD)) out.diffuse.r2 += shortD;
        if (shortS > 0.0 && std::isfinite(shortS)) out.glossy.r2 += shortS;
    }
    return out;
}

glm::dvec3 shade(const LightPair& lights, const glm::dvec3& p, const glm::dvec3& n, const glm::dvec3& eye,
                 const glm::dvec3& rhoD, const glm::dvec3& fs, double k) {
    const glm::dvec3 od = lights.diffuse.position - p, os = lights.glossy.position - p;
    const double radius2 = lights.diffuse.sphereRadius * lights.diffuse.sphereRadius;
    const double cosTheta =
        horizonFactor(glm::dot(n, unit(od)), radius2 > 0.0 ? radius2 / (radius2 + glm::dot(od, od)) : 0.0);
    const glm::dvec3 dirS = unit(os);
    const double lobe = glm::dot(n, dirS) > 0.0 ? lobePower(cosGamma(n, dirS, unit(eye - p)), k) : 0.0;
    // eq. 10 with D = |x - l'|^2 + rbar^2
    return rhoD / kPi * lights.diffuse.radiance * (cosTheta / (glm::dot(od, od) + lights.diffuse.r2)) +
           fs * lights.glossy.radiance * (lobe / (glm::dot(os, os) + lights.glossy.r2));
}

Run run(std::span<const gi::VirtualAreaLight> vals, std::span<const Point> points, const glm::dvec3& eye,
        const Options& options, bool withOcclusion) {
    Run r;
    for (const Point& x : points) {
        r.gathers.push_back(gather(vals, x, eye, options));
        r.lights.push_back(renormalise(r.gathers.back(), x, eye, options));
    }
    r.occlusion.assign(points.size(), glm::dvec2(0.0));
    r.occluded = r.lights;
    for (std::size_t i = 0; withOcclusion && i < points.size(); ++i) {
        r.occlusion[i] = occlusion(points, r.lights, i);
        r.occluded[i].diffuse.radiance *= 1.0 - r.occlusion[i].x;
        r.occluded[i].glossy.radiance *= 1.0 - r.occlusion[i].y;
    }
    return r;
}

} // namespace lightskin::test::paper
