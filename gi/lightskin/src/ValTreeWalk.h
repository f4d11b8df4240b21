#pragma once
// The walk of the gather with a cut (ValTreeReference.h), for one receiver, in double: shared by the
// reference (ValTreeReference.cpp) and the CPU backend (CpuValTreeGather.cpp), as the formulas are
// shared with the shader (val_tree_math.glsl). gather_tree.comp is the same walk in GLSL.
#include "ValTreeMath.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/lightskin/GatherSums.h>
#include <lightskin/gi/lightskin/ValTree.h>

#include <array>
#include <span>

namespace lightskin::gi::gather::walk {

namespace m = refmath;

inline void add(GatherSums& s, const m::GatherSample& g, const glm::dvec3& variance, bool glossy) {
    s.irradiance += g.irradiance;
    s.weightD += g.weightD;
    s.offsetD += g.offset * g.weightD;
    s.r2D += g.r2 * g.weightD;
    s.momentD += (g.offset * g.offset + variance) * g.weightD;
    if (glossy) {
        s.glossy += g.glossy;
        s.weightS += g.weightS;
        s.offsetS += g.offset * g.weightS;
        s.r2S += g.r2 * g.weightS;
        s.momentS += (glm::dot(g.offset, g.offset) + variance.x + variance.y + variance.z) * g.weightS;
    }
}

inline double boxDistance2(const ValClusterD& c, const glm::dvec3& x) {
    const glm::dvec3 q = glm::max(glm::max(c.boxMin - x, x - c.boxMax), glm::dvec3(0.0));
    return glm::dot(q, q);
}

inline bool within(const glm::dvec3& bound, double threshold, const glm::dvec3& estimate) {
    return bound.x <= threshold * estimate.x && bound.y <= threshold * estimate.y && bound.z <= threshold * estimate.z;
}

/// Adds receiver x's cut of `tree` to `s` (zero on entry), its certified bound to `certified`, its counts
/// to `totals`. eps_l = parameters.epsilonL per VAL (0 for the GPU layout, which adds it later).
inline void walkCut(const ValTreeD& tree, std::span<const VirtualAreaLight> lights, const Receiver& x,
                    const glm::dvec3& toEye, const GatherParameters& parameters, double threshold, GatherSums& s,
                    CutBound& certified, CutStatistics& totals) {
    if (tree.nodes.empty()) return;
    const double ck = parameters.cParameter * (x.exponent + 1.0);
    // The running estimate is lightcuts': the sum over the current cut, i.e. what was taken plus the
    // one-light approximations of the clusters still on the stack (and of the one being judged).
    struct Pending {
        std::uint32_t node;
        glm::dvec3 irradiance, glossy;
    };
    const auto approximate = [&](std::uint32_t node) {
        const ValClusterD& c = tree.nodes[node];
        Pending p{node, glm::dvec3(0.0), glm::dvec3(0.0)};
        const m::GatherSample g =
            c.child1 == kValTreeLeaf
                ? m::ls_gatherSample(x.position, x.normal, glm::dvec3(lights[c.child0].position),
                                     glm::dvec3(lights[c.child0].normal), double(lights[c.child0].area),
                                     glm::dvec3(lights[c.child0].flux), toEye, x.exponent, ck, 0.0,
                                     parameters.nearField)
                : m::vt_clusterSample(x.position, x.normal, c.position, c.axis, c.normalScale, c.r2Mean, c.r2Sum,
                                      c.flux, toEye, x.exponent, ck);
        p.irradiance = g.irradiance;
        p.glossy = g.glossy;
        return p;
    };
    std::array<Pending, kValTreeMaxDepth + 1> stack{};
    glm::dvec3 pendingD(0.0), pendingS(0.0);
    std::size_t top = 0;
    stack[top++] = approximate(0);
    while (top > 0) {
        const Pending current = stack[--top];
        pendingD -= current.irradiance;
        pendingS -= current.glossy;
        const ValClusterD& c = tree.nodes[current.node];
        ++totals.visited;
        if (c.child1 == kValTreeLeaf) {
            const VirtualAreaLight& l = lights[c.child0];
            add(s,
                m::ls_gatherSample(x.position, x.normal, glm::dvec3(l.position), glm::dvec3(l.normal), double(l.area),
                                   glm::dvec3(l.flux), toEye, x.exponent, ck, parameters.epsilonL,
                                   parameters.nearField),
                glm::dvec3(0.0), parameters.glossy);
            ++totals.leaves;
            continue;
        }
        const glm::dvec2 g = m::vt_clusterBound(x.position, x.normal, c.boxMin, c.boxMax, c.axis, c.coneAngle, c.r2Min,
                                                c.r2Sum, toEye, x.exponent, parameters.nearField);
        const glm::dvec3 boundD = c.flux * (g.x / m::kPi);
        const glm::dvec3 boundS = c.flux * (ck * g.y / m::kPi);
        const glm::dvec3 estimateD = s.irradiance + glm::max(pendingD, glm::dvec3(0.0)) + current.irradiance;
        const glm::dvec3 estimateS = s.glossy + glm::max(pendingS, glm::dvec3(0.0)) + current.glossy;
        if (within(boundD, threshold, estimateD) && (!parameters.glossy || within(boundS, threshold, estimateS))) {
            m::GatherSample sample = m::vt_clusterSample(x.position, x.normal, c.position, c.axis, c.normalScale,
                                                         c.r2Mean, c.r2Sum, c.flux, toEye, x.exponent, ck);
            sample.weightD += c.count * parameters.epsilonL;
            sample.weightS += c.count * parameters.epsilonL;
            add(s, sample, c.variance, parameters.glossy); // as clusterAsOneLight(), without recomputing toEye
            certified.irradiance += boundD;
            if (parameters.glossy) certified.glossy += boundS;
            ++(g.x > 0.0 || g.y > 0.0 ? totals.clusters : totals.skipped);
            continue;
        }
        // nearer child on top: judged first, while the farther one still counts in the estimate
        const bool firstNearer =
            boxDistance2(tree.nodes[c.child0], x.position) <= boxDistance2(tree.nodes[c.child1], x.position);
        LIGHTSKIN_ASSERT(top + 2 <= kValTreeMaxDepth + 1, "lightskin::gi::gather::walk::walkCut(): stack");
        for (const std::uint32_t child : {firstNearer ? c.child1 : c.child0, firstNearer ? c.child0 : c.child1}) {
            stack[top] = approximate(child);
            pendingD += stack[top].irradiance;
            pendingS += stack[top].glossy;
            ++top;
        }
    }
}

} // namespace lightskin::gi::gather::walk
