// The VAL cluster tree's builder (ValTree.h). Statistics are combined in double for both node types
// and rounded outward (boxes) or down (r2Min) when stored as float, so that the float bound of
// val_tree_math.glsl still holds for every member VAL.
#include <lightskin/core/Error.h>
#include <lightskin/gi/lightskin/ValTree.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <utility>

namespace lightskin::gi {
namespace {

using glm::dvec3;

bool valid(const VirtualAreaLight& l) { return l.area > 0.0f; } // false for NaN, like ls_gatherSample

double channelSum(const dvec3& v) { return v.x + v.y + v.z; }

double angleBetween(const dvec3& a, const dvec3& b) { return std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0)); }

float roundDown(double v) {
    const float f = float(v);
    return double(f) > v ? std::nextafter(f, -INFINITY) : f;
}
float roundUp(double v) {
    const float f = float(v);
    return double(f) < v ? std::nextafter(f, INFINITY) : f;
}

template <class Real>
ValClusterT<Real> store(const ValClusterD& d) {
    if constexpr (std::is_same_v<Real, double>) {
        return d;
    } else {
        ValCluster f;
        f.position = glm::vec3(d.position);
        f.r2Mean = float(d.r2Mean);
        f.axis = glm::vec3(d.axis);
        f.normalScale = float(d.normalScale);
        f.flux = glm::vec3(d.flux);
        f.r2Sum = float(d.r2Sum);
        f.boxMin = glm::vec3(roundDown(d.boxMin.x), roundDown(d.boxMin.y), roundDown(d.boxMin.z));
        f.boxMax = glm::vec3(roundUp(d.boxMax.x), roundUp(d.boxMax.y), roundUp(d.boxMax.z));
        // the float axis differs from the double one by ~1e-7 rad: covered by the shader's slack
        f.coneAngle = roundUp(d.coneAngle);
        f.r2Min = roundDown(d.r2Min);
        f.variance = glm::vec3(d.variance);
        f.count = float(d.count);
        f.child0 = d.child0;
        f.child1 = d.child1;
        return f;
    }
}

ValClusterD leaf(const VirtualAreaLight& l, std::uint32_t index) {
    ValClusterD c;
    c.position = dvec3(l.position);
    const double r2 = double(l.area) / std::numbers::pi;
    c.r2Mean = r2;
    c.r2Sum = r2;
    c.r2Min = r2;
    const dvec3 n(l.normal);
    const double length = glm::length(n);
    // a zero normal emits nothing (cos(theta_j) = 0); any axis with scale 0 says the same
    c.axis = length > 0.0 ? n / length : dvec3(0, 0, 1);
    c.normalScale = length > 0.0 ? 1.0 : 0.0;
    c.coneAngle = length > 0.0 ? 0.0 : std::numbers::pi;
    c.flux = dvec3(l.flux);
    c.boxMin = c.position;
    c.boxMax = c.position;
    c.variance = dvec3(0.0);
    c.count = 1.0;
    c.child0 = index;
    c.child1 = kValTreeLeaf;
    return c;
}

ValClusterD combine(const ValClusterD& a, const ValClusterD& b) {
    ValClusterD c;
    c.flux = a.flux + b.flux;
    const double phiA = channelSum(a.flux), phiB = channelSum(b.flux);
    // flux weights; black clusters (no flux, so no light either) fall back to counts for the geometry
    const bool byFlux = phiA + phiB > 0.0;
    const double wa = byFlux ? phiA : a.count, wb = byFlux ? phiB : b.count;
    const double w = wa + wb;
    c.position = (wa * a.position + wb * b.position) / w;
    const dvec3 da = a.position - c.position, db = b.position - c.position;
    c.variance = (wa * (a.variance + da * da) + wb * (b.variance + db * db)) / w; // parallel axis theorem
    const dvec3 normalSum = wa * a.normalScale * a.axis + wb * b.normalScale * b.axis;
    const double length = glm::length(normalSum);
    c.normalScale = std::min(length / w, 1.0);
    if (length > 0.0) {
        c.axis = normalSum / length;
        c.coneAngle = std::min(std::numbers::pi, std::max(angleBetween(c.axis, a.axis) + a.coneAngle,
                                                          angleBetween(c.axis, b.axis) + b.coneAngle));
    } else {
        c.axis = dvec3(0, 0, 1);
        c.coneAngle = std::numbers::pi;
    }
    c.r2Sum = a.r2Sum + b.r2Sum;
    c.r2Mean = c.r2Sum > 0.0 ? (a.r2Mean * a.r2Sum + b.r2Mean * b.r2Sum) / c.r2Sum : 0.0;
    c.r2Min = std::min(a.r2Min, b.r2Min);
    c.r2Mean = std::max(c.r2Mean, c.r2Min); // a mean of equal values may round below them; the bound needs >=
    c.boxMin = glm::min(a.boxMin, b.boxMin);
    c.boxMax = glm::max(a.boxMax, b.boxMax);
    c.count = a.count + b.count;
    return c;
}

template <class Real>
struct Builder {
    std::span<const VirtualAreaLight> vals;
    ValTreeT<Real>& tree;
    std::uint32_t next = 0;

    // Builds the node for scratchOrder[first, last) at the next free index; returns its double statistics.
    ValClusterD build(std::size_t first, std::size_t last, int level) {
        tree.depth = std::max(tree.depth, level);
        const std::uint32_t index = next++;
        std::vector<std::uint32_t>& order = tree.scratchOrder;
        if (last - first == 1) {
            const ValClusterD c = leaf(vals[order[first]], order[first]);
            tree.nodes[index] = store<Real>(c);
            return c;
        }
        glm::vec3 lo = vals[order[first]].position, hi = lo;
        for (std::size_t i = first + 1; i < last; ++i) {
            lo = glm::min(lo, vals[order[i]].position);
            hi = glm::max(hi, vals[order[i]].position);
        }
        const glm::vec3 extent = hi - lo;
        const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
        const std::size_t middle = first + (last - first) / 2;
        const auto begin = order.begin();
        // ties broken by index: the tree does not depend on the standard library's nth_element
        std::nth_element(begin + std::ptrdiff_t(first), begin + std::ptrdiff_t(middle), begin + std::ptrdiff_t(last),
                         [&](std::uint32_t i, std::uint32_t j) {
                             const float pi = vals[i].position[axis], pj = vals[j].position[axis];
                             return pi < pj || (pi == pj && i < j);
                         });
        const std::uint32_t child0 = next;
        const ValClusterD a = build(first, middle, level + 1);
        const std::uint32_t child1 = next;
        const ValClusterD b = build(middle, last, level + 1);
        ValClusterD c = combine(a, b);
        c.child0 = child0;
        c.child1 = child1;
        tree.nodes[index] = store<Real>(c);
        return c;
    }
};

// A node as stored: the quadtree builder keeps its node index and subtree depth in the padding.
template <class Real>
ValClusterT<Real> storeNode(ValClusterD c) {
    c.padding0 = c.padding1 = 0;
    return store<Real>(c);
}

} // namespace

template <class Real>
void buildValTreeInto(std::span<const VirtualAreaLight> vals, ValTreeT<Real>& tree) {
    tree.scratchOrder.clear();
    for (std::size_t i = 0; i < vals.size(); ++i)
        if (valid(vals[i])) tree.scratchOrder.push_back(std::uint32_t(i));
    LIGHTSKIN_ASSERT(vals.size() < kValTreeLeaf, "lightskin::gi::buildValTreeInto(): too many VALs");
    const std::size_t n = tree.scratchOrder.size();
    tree.depth = 0;
    tree.nodes.resize(n == 0 ? 0 : 2 * n - 1);
    if (n == 0) return;
    Builder<Real> builder{vals, tree};
    builder.build(0, n, 1);
    LIGHTSKIN_ASSERT(builder.next == tree.nodes.size(), "lightskin::gi::buildValTreeInto(): node count");
    LIGHTSKIN_ASSERT(tree.depth <= kValTreeMaxDepth, "lightskin::gi::buildValTreeInto(): tree too deep");
}

template <class Real>
void buildValQuadtreeInto(std::span<const VirtualAreaLight> vals, std::span<const std::uint32_t> keys,
                          std::uint32_t width, std::uint32_t height, ValTreeT<Real>& tree) {
    LIGHTSKIN_ASSERT(keys.size() == vals.size(), "lightskin::gi::buildValQuadtreeInto(): one key per VAL");
    LIGHTSKIN_ASSERT(vals.size() < kValTreeLeaf, "lightskin::gi::buildValQuadtreeInto(): too many VALs");
    const std::size_t pixels = std::size_t(width) * std::size_t(height);
    LIGHTSKIN_ASSERT(pixels < 0x7FFFFFFFu, "lightskin::gi::buildValQuadtreeInto(): image too large");
    // Level 0: the image; a cell holds the index of its VAL's cluster in scratchLevel[0], or -1.
    std::vector<std::int32_t>& pixelCells = tree.scratchCells[0];
    pixelCells.assign(pixels, -1);
    std::vector<std::uint32_t>& order = tree.scratchOrder;
    order.clear();
    for (std::size_t i = 0; i < vals.size(); ++i) {
        if (!valid(vals[i])) continue;
        const std::uint32_t key = keys[i];
        if (key >= pixels)
            throw Error("VAL keys", std::nullopt,
                        "VAL " + std::to_string(i) + " has pixel key " + std::to_string(key) + ", outside the " +
                            std::to_string(width) + "x" + std::to_string(height) + " image");
        if (pixelCells[key] >= 0)
            throw Error("VAL keys", std::nullopt,
                        "VALs " + std::to_string(order[std::size_t(pixelCells[key])]) + " and " + std::to_string(i) +
                            " share pixel " + std::to_string(key));
        pixelCells[key] = std::int32_t(order.size());
        order.push_back(std::uint32_t(i));
    }
    const std::size_t n = order.size();
    tree.depth = 0;
    tree.nodes.resize(n == 0 ? 0 : 2 * n - 1);
    if (n == 0) return;
    // Nodes are numbered in creation order c (leaves first, the root last) and stored at last - c, so
    // that the root is node 0 as the walk expects.
    const auto last = std::uint32_t(tree.nodes.size() - 1);
    std::vector<ValClusterD>& leaves = tree.scratchLevel[0];
    leaves.resize(n);
    for (std::int64_t k = 0; k < std::int64_t(n); ++k) {
        const std::uint32_t i = order[std::size_t(k)];
        ValClusterD c = leaf(vals[i], i);
        c.padding0 = last - std::uint32_t(k); // node index
        c.padding1 = 1;                       // subtree depth
        leaves[std::size_t(k)] = c;
        tree.nodes[c.padding0] = storeNode<Real>(c);
    }
    std::uint32_t created = std::uint32_t(n);
    std::uint32_t w = width, h = height;
    int current = 0;
    bool alongU = true;
    std::vector<std::uint32_t>& rows = tree.scratchRows;
    while (w > 1 || h > 1) {
        // pair neighbours along u and v in turn (2x2 -> 1 every two levels); a side of 1 stops pairing
        const bool pairU = (alongU && w > 1) || h == 1;
        alongU = !pairU;
        const std::uint32_t nw = pairU ? (w + 1) / 2 : w, nh = pairU ? h : (h + 1) / 2;
        const std::vector<std::int32_t>& inCells = tree.scratchCells[current];
        const std::vector<ValClusterD>& in = tree.scratchLevel[current];
        std::vector<std::int32_t>& outCells = tree.scratchCells[1 - current];
        std::vector<ValClusterD>& out = tree.scratchLevel[1 - current];
        outCells.resize(std::size_t(nw) * nh);
        const auto children = [&](std::uint32_t x, std::uint32_t y) {
            const std::size_t a = pairU ? std::size_t(y) * w + 2 * x : std::size_t(2 * y) * w + x;
            const bool hasB = pairU ? 2 * x + 1 < w : 2 * y + 1 < h;
            const std::int32_t b = hasB ? inCells[pairU ? a + 1 : a + w] : -1;
            return std::pair<std::int32_t, std::int32_t>(inCells[a], b);
        };
        // Pass 1: non-empty cells and new nodes per row, then their row offsets; pass 2 fills the rows
        // independently. One thread: OpenMP over the rows (3 barriers per level, ~20 levels) measured
        // 675 ms instead of 3 ms at 19k VALs, 1056 instead of 247 ms at 518k, on the loaded 2-core machine
        // (docs/BENCHMARKS.md "VAL tree"); the passes are kept so that rows can go parallel on a free one.
        rows.assign(2 * (std::size_t(nh) + 1), 0u);
        for (std::int64_t yy = 0; yy < std::int64_t(nh); ++yy) {
            const auto y = std::uint32_t(yy);
            std::uint32_t nonEmpty = 0, pairs = 0;
            for (std::uint32_t x = 0; x < nw; ++x) {
                const auto [a, b] = children(x, y);
                nonEmpty += (a >= 0 || b >= 0) ? 1u : 0u;
                pairs += (a >= 0 && b >= 0) ? 1u : 0u;
            }
            rows[2 * std::size_t(y) + 2] = nonEmpty;
            rows[2 * std::size_t(y) + 3] = pairs;
        }
        for (std::size_t y = 0; y < nh; ++y) {
            rows[2 * y + 2] += rows[2 * y];
            rows[2 * y + 3] += rows[2 * y + 1];
        }
        out.resize(rows[2 * std::size_t(nh)]);
        // Pass 2: a cell with one child carries it up unchanged; with two, a new node.
        for (std::int64_t yy = 0; yy < std::int64_t(nh); ++yy) {
            const auto y = std::uint32_t(yy);
            std::uint32_t slot = rows[2 * std::size_t(y)], pair = created + rows[2 * std::size_t(y) + 1];
            for (std::uint32_t x = 0; x < nw; ++x) {
                const auto [a, b] = children(x, y);
                std::int32_t& cell = outCells[std::size_t(y) * nw + x];
                if (a < 0 && b < 0) {
                    cell = -1;
                    continue;
                }
                if (a < 0 || b < 0) {
                    out[slot] = in[std::size_t(a < 0 ? b : a)];
                } else {
                    const ValClusterD &ca = in[std::size_t(a)], &cb = in[std::size_t(b)];
                    ValClusterD c = combine(ca, cb);
                    c.child0 = ca.padding0;
                    c.child1 = cb.padding0;
                    c.padding0 = last - pair++;
                    c.padding1 = std::max(ca.padding1, cb.padding1) + 1;
                    tree.nodes[c.padding0] = storeNode<Real>(c);
                    out[slot] = c;
                }
                cell = std::int32_t(slot++);
            }
        }
        created += rows[2 * std::size_t(nh) + 1];
        w = nw;
        h = nh;
        current = 1 - current;
    }
    LIGHTSKIN_ASSERT(created == tree.nodes.size() && tree.scratchLevel[current].size() == 1,
                     "lightskin::gi::buildValQuadtreeInto(): node count");
    tree.depth = int(tree.scratchLevel[current][0].padding1);
    LIGHTSKIN_ASSERT(tree.depth <= kValTreeMaxDepth, "lightskin::gi::buildValQuadtreeInto(): tree too deep");
}

template void buildValTreeInto<float>(std::span<const VirtualAreaLight>, ValTreeT<float>&);
template void buildValTreeInto<double>(std::span<const VirtualAreaLight>, ValTreeT<double>&);
template void buildValQuadtreeInto<float>(std::span<const VirtualAreaLight>, std::span<const std::uint32_t>,
                                          std::uint32_t, std::uint32_t, ValTreeT<float>&);
template void buildValQuadtreeInto<double>(std::span<const VirtualAreaLight>, std::span<const std::uint32_t>,
                                           std::uint32_t, std::uint32_t, ValTreeT<double>&);

} // namespace lightskin::gi
