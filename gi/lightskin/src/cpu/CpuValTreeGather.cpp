#include "CpuValTreeGather.h"

#include "CpuGatherKernels.h"
#include "lightskin/src/ValTreeWalk.h"

#include <lightskin/core/Error.h>

#include <omp.h>
#include <string>

namespace lightskin::gi::cpu {

void ValTreeCut::gather(std::span<const VirtualAreaLight> lights, std::span<const glm::dvec3> positions,
                        std::span<const glm::dvec3> normals, std::span<const double> exponents, const glm::dvec3& eye,
                        double c, bool glossy, bool moments, bool nearField, double threshold, int threads, float* sums,
                        std::size_t stride, const ValTreeImage& image) {
    LIGHTSKIN_ASSERT(threshold > 0.0, "lightskin::gi::cpu::ValTreeCut::gather(): threshold must be > 0");
    LIGHTSKIN_ASSERT(positions.size() == normals.size() && positions.size() == exponents.size() &&
                         positions.size() <= stride,
                     "lightskin::gi::cpu::ValTreeCut::gather(): one position, normal and exponent per point");
    stats_ = ValTreeCutStats{};
    // Depth VALs come with their pixels: the image's quadtree costs O(pixels) and no sort (ValTree.h)
    stats_.quadtree = !image.keys.empty();
    if (stats_.quadtree) {
        if (image.keys.size() != lights.size())
            throw Error("VAL keys", std::nullopt,
                        std::to_string(image.keys.size()) + " pixel keys for " + std::to_string(lights.size()) +
                            " VALs");
        buildValQuadtreeInto(lights, image.keys, image.width, image.height, tree_);
    } else {
        buildValTreeInto(lights, tree_);
    }
    stats_.nodes = std::uint32_t(tree_.nodes.size());
    gather::GatherParameters parameters;
    parameters.cParameter = c;
    parameters.epsilonL = 0.0; // folded in later, as on the GL path
    parameters.glossy = glossy;
    parameters.nearField = nearField;
    std::uint64_t visited = 0, taken = 0;
    const auto points = std::ptrdiff_t(positions.size());
    // a point's sums depend on that point alone: any thread split gives the same numbers
#pragma omp parallel for num_threads(threads) schedule(dynamic, 16) reduction(+ : visited, taken)
    for (std::ptrdiff_t p = 0; p < points; ++p) {
        const auto i = std::size_t(p);
        gather::Receiver x;
        x.position = positions[i];
        x.normal = normals[i];
        x.exponent = exponents[i];
        gather::GatherSums s;
        gather::CutBound certified;
        gather::CutStatistics counts;
        gather::walk::walkCut(tree_, lights, x, refmath::ls_toEye(x.position, eye), parameters, threshold, s,
                                 certified, counts);
        visited += counts.visited;
        taken += counts.clusters + counts.skipped + counts.leaves;
        const double values[kGatherSums] = {s.irradiance.x, s.irradiance.y, s.irradiance.z, s.r2D,       s.offsetD.x,
                                            s.offsetD.y,    s.offsetD.z,    s.weightD,      s.glossy.x,  s.glossy.y,
                                            s.glossy.z,     s.r2S,          s.offsetS.x,    s.offsetS.y, s.offsetS.z,
                                            s.weightS,      s.momentD.x,    s.momentD.y,    s.momentD.z, s.momentS};
        for (std::size_t k = 0; k < kGatherSums; ++k) {
            const bool moment = k >= 16;
            sums[k * stride + i] = moment && !moments ? 0.0f : float(values[k]);
        }
    }
    stats_.visited = visited;
    stats_.taken = taken;
}

} // namespace lightskin::gi::cpu
