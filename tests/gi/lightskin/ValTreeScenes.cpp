#include "ValTreeScenes.h"

#include "common/GatherTestScenes.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <random>

namespace lightskin::test {

namespace ref = gi::reference;
using glm::dvec3;
using glm::vec3;

// Receivers: the sparse points of a sphere of radius 0.3 m at `centre`, outward normals, Phong k = 20.
std::vector<ref::Receiver> sphereReceivers(const vec3& centre, int stacks, int slices) {
    const TriangleMesh mesh = makeSphere(0.3f, stacks, slices);
    std::vector<ref::Receiver> out;
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
        ref::Receiver r;
        r.position = dvec3(mesh.positions[i] + centre);
        r.normal = glm::normalize(dvec3(mesh.normals[i]));
        r.exponent = 20.0;
        out.push_back(r);
    }
    return out;
}

// A room around a sphere: floor (radiance 0.8 white), a red wall and a dim back wall, all facing the
// sphere; 3 x 64^2 = 12288 VALs.
ValTreeScene roomScene() {
    ValTreeScene s{"room", {}, sphereReceivers({0, 0, 0}, 8, 12)};
    const auto add = [&](const std::vector<gi::VirtualAreaLight>& v) {
        s.vals.insert(s.vals.end(), v.begin(), v.end());
    };
    add(squareEmitter({0, 0, -0.5f}, {0, 0, 1}, 3.0f, 64, vec3(0.8f)));
    add(squareEmitter({-1.0f, 0, 0.5f}, {1, 0, 0}, 3.0f, 64, vec3(0.9f, 0.1f, 0.1f)));
    add(squareEmitter({0, 1.5f, 0.5f}, {0, -1, 0}, 3.0f, 64, vec3(0.05f)));
    return s;
}

// Pseudo-random VALs in a box around the sphere, normals toward it (a noisy depth cloud).
ValTreeScene cloudScene() {
    return {"cloud", randomVals(8000, {-2, -2, -2}, {2, 2, 2}, {0, 0, 0}, 1e-3f, 7), sphereReceivers({0, 0, 0}, 6, 10)};
}

// A plane receiving light with VALs touching it (contact: VALs at distance ~0 of receivers).
ValTreeScene contactScene() {
    ValTreeScene s{"contact", squareEmitter({0, 0, 0.001f}, {0, 0, -1}, 1.0f, 80, vec3(1.0f)), {}};
    for (int i = 0; i < 64; ++i) {
        ref::Receiver r;
        r.position = dvec3(-0.45 + 0.9 * (i % 8) / 7.0, -0.45 + 0.9 * (i / 8) / 7.0, 0.0);
        r.normal = dvec3(0, 0, 1);
        s.receivers.push_back(r);
    }
    return s;
}

// VALs on both sides of the receivers, half facing away (normal cones of up to 180 degrees).
ValTreeScene bothSidesScene() {
    ValTreeScene s{"both_sides", {}, sphereReceivers({0, 0, 0}, 6, 10)};
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (int i = 0; i < 6000; ++i) {
        const vec3 p(u(rng) * 2.0f, u(rng) * 2.0f, u(rng) * 2.0f);
        const vec3 n = glm::normalize(vec3(u(rng), u(rng), u(rng)) + vec3(0, 0, 1e-3f));
        s.vals.push_back(disc(p, n, 2e-3f, vec3(1.0f, 0.5f, 0.25f) * 2e-3f));
    }
    return s;
}

// Flux over 12 orders of magnitude: dim background and a few very bright VALs (specular highlights).
ValTreeScene fluxRangeScene() {
    ValTreeScene s{"flux_range", randomVals(5000, {-2, -2, -2}, {2, 2, 2}, {0, 0, 0}, 1e-3f, 11),
                   sphereReceivers({0, 0, 0}, 6, 10)};
    for (std::size_t i = 0; i < s.vals.size(); ++i) s.vals[i].flux *= (i % 97 == 0) ? 1e6f : 1e-6f;
    return s;
}

std::vector<ValTreeScene> valTreeScenes() {
    return {roomScene(), cloudScene(), contactScene(), bothSidesScene(), fluxRangeScene()};
}

// Pixel keys for a scene's VALs (ValSetView::keys), as an orthographic depth camera looking along z
// would give them: columns by x rank, rows by y rank within a column, so that neighbouring pixels hold
// nearby VALs (the premise of the image quadtree). Every 8th row stays empty (invalid depth pixels
// leave holes), so the quadtree meets empty cells, single-child carries and a non-power-of-two image.
ImageKeys imageKeys(const std::vector<gi::VirtualAreaLight>& vals) {
    const std::size_t n = vals.size();
    ImageKeys image;
    image.keys.resize(n);
    const auto rows = std::size_t(std::ceil(std::sqrt(double(n))));
    image.width = std::uint32_t((n + rows - 1) / rows);
    image.height = std::uint32_t(rows + rows / 7);
    std::vector<std::size_t> order(n);
    for (std::size_t i = 0; i < n; ++i) order[i] = i;
    const auto by = [&](int axis) {
        return [&vals, axis](std::size_t a, std::size_t b) {
            return vals[a].position[axis] < vals[b].position[axis] ||
                   (vals[a].position[axis] == vals[b].position[axis] && a < b);
        };
    };
    std::sort(order.begin(), order.end(), by(0));
    for (std::size_t first = 0; first < n; first += rows) {
        const auto begin = order.begin() + std::ptrdiff_t(first);
        const auto end = order.begin() + std::ptrdiff_t(std::min(n, first + rows));
        std::sort(begin, end, by(1));
        for (auto it = begin; it != end; ++it) {
            const std::size_t row = std::size_t(it - begin);
            image.keys[*it] = std::uint32_t((row + row / 7) * image.width + first / rows);
        }
    }
    return image;
}

// The GPU tree as a double tree for the reference walk: the same numbers, widened.
gi::ValTreeD widenValTree(const std::vector<gi::ValCluster>& nodes) {
    gi::ValTreeD d;
    d.nodes.resize(nodes.size());
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        const gi::ValCluster& n = nodes[i];
        gi::ValClusterD& w = d.nodes[i];
        w.position = dvec3(n.position);
        w.r2Mean = n.r2Mean;
        w.axis = dvec3(n.axis);
        w.normalScale = n.normalScale;
        w.flux = dvec3(n.flux);
        w.r2Sum = n.r2Sum;
        w.boxMin = dvec3(n.boxMin);
        w.coneAngle = n.coneAngle;
        w.boxMax = dvec3(n.boxMax);
        w.r2Min = n.r2Min;
        w.variance = dvec3(n.variance);
        w.count = n.count;
        w.child0 = n.child0;
        w.child1 = n.child1;
    }
    d.depth = gi::kValTreeMaxDepth;
    return d;
}

} // namespace lightskin::test
