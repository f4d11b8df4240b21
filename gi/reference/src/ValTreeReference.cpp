// Reference of the gather with a cut (ValTreeReference.h): the walk and bookkeeping only; the formulas
// are val_tree_math.glsl's and lightskin_math.glsl's through ValTreeMath.h.
#include "lightskin/src/ValTreeWalk.h"

#include <lightskin/core/Error.h>
#include <lightskin/gi/reference/ValTreeReference.h>

namespace lightskin::gi::reference {

namespace m = refmath;
using gather::walk::add;

CutBound clusterErrorBound(const ValClusterD& c, const Receiver& x, const glm::dvec3& eye,
                           const GatherParameters& parameters) {
    const glm::dvec2 g = m::vt_clusterBound(x.position, x.normal, c.boxMin, c.boxMax, c.axis, c.coneAngle, c.r2Min,
                                            c.r2Sum, m::ls_toEye(x.position, eye), x.exponent, parameters.nearField);
    const double ck = parameters.cParameter * (x.exponent + 1.0);
    return {c.flux * (g.x / m::kPi), parameters.glossy ? c.flux * (ck * g.y / m::kPi) : glm::dvec3(0.0)};
}

GatherSums clusterAsOneLight(const ValClusterD& c, const Receiver& x, const glm::dvec3& eye,
                             const GatherParameters& parameters) {
    const double ck = parameters.cParameter * (x.exponent + 1.0);
    m::GatherSample sample = m::vt_clusterSample(x.position, x.normal, c.position, c.axis, c.normalScale, c.r2Mean,
                                                 c.r2Sum, c.flux, m::ls_toEye(x.position, eye), x.exponent, ck);
    sample.weightD += c.count * parameters.epsilonL;
    sample.weightS += c.count * parameters.epsilonL;
    GatherSums s;
    add(s, sample, c.variance, parameters.glossy);
    return s;
}

void gatherWithCutInto(const ValTreeD& tree, std::span<const VirtualAreaLight> lights,
                       std::span<const Receiver> receivers, const glm::dvec3& eye, const GatherParameters& parameters,
                       double threshold, std::vector<GatherSums>& out, std::vector<CutBound>* bounds,
                       CutStatistics* statistics) {
    LIGHTSKIN_ASSERT(threshold >= 0.0, "lightskin::gi::reference::gatherWithCutInto(): threshold must be >= 0");
    out.assign(receivers.size(), GatherSums{});
    if (bounds) bounds->assign(receivers.size(), CutBound{});
    CutStatistics totals;
    for (std::size_t i = 0; i < receivers.size(); ++i) {
        CutBound certified;
        gather::walk::walkCut(tree, lights, receivers[i], m::ls_toEye(receivers[i].position, eye), parameters,
                              threshold, out[i], certified, totals);
        if (bounds) (*bounds)[i] = certified;
    }
    if (statistics) *statistics = totals;
}

} // namespace lightskin::gi::reference
