// lightskin_bench_valtree: the gather with a cut through the VAL tree against the flat gather,
// both on the double-precision CPU reference (gi/src/reference), one run, side by side: time against the
// VAL count (18k, 72k, 291k, 512k: Kinect VAL maps at strides 4, 2, 1 and 1080p at stride 2), the
// error of the cut against the flat gather (relative MSE of L'_d and L'_s over the sparse points), the
// nodes visited per sparse point (the cut's cost) and the thresholds as the knob. A separate program,
// never a test; the numbers go to docs/BENCHMARKS.md with this command:
//   build/bench/lightskin_bench_valtree [points-per-side=16] [glossy=1] [quadtree=0]
// quadtree=1: the image quadtree (buildValQuadtreeInto) of the four r x r grids stacked into an r x 4r
// image, as the CPU backend builds it for depth VALs, instead of the BVH.
// Scene: an open box room (floor and three walls, 3 m, each a grid of r x r disc VALs of radiance
// 0.3..0.9) around a sphere of radius 0.3 m whose vertices are the sparse points.
#include <lightskin/gi/reference/LightSkinReference.h>
#include <lightskin/gi/lightskin/ValTree.h>
#include <lightskin/gi/reference/ValTreeReference.h>

#include <glm/geometric.hpp>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <numbers>
#include <string>
#include <vector>

namespace {

using namespace lightskin;
namespace ref = gi::reference;

void square(std::vector<gi::VirtualAreaLight>& out, const glm::vec3& centre, const glm::vec3& normal,
            const glm::vec3& u, float size, int r, const glm::vec3& radiance) {
    const glm::vec3 v = glm::cross(normal, u);
    const float cell = size / float(r);
    for (int i = 0; i < r; ++i)
        for (int j = 0; j < r; ++j) {
            gi::VirtualAreaLight l;
            l.position =
                centre + u * (cell * (float(i) + 0.5f) - 0.5f * size) + v * (cell * (float(j) + 0.5f) - 0.5f * size);
            l.normal = normal;
            l.area = cell * cell;
            // a gentle pattern so the clusters are not uniform
            const float shade = 0.6f + 0.3f * std::sin(0.37f * float(i)) * std::cos(0.23f * float(j));
            l.flux = radiance * (shade * std::numbers::pi_v<float> * l.area);
            out.push_back(l);
        }
}

std::vector<gi::VirtualAreaLight> room(int r) {
    std::vector<gi::VirtualAreaLight> vals;
    square(vals, {0, 0, -0.5f}, {0, 0, 1}, {1, 0, 0}, 3.0f, r, glm::vec3(0.8f));
    square(vals, {-1.5f, 0, 1.0f}, {1, 0, 0}, {0, 1, 0}, 3.0f, r, glm::vec3(0.9f, 0.2f, 0.2f));
    square(vals, {1.5f, 0, 1.0f}, {-1, 0, 0}, {0, 1, 0}, 3.0f, r, glm::vec3(0.2f, 0.9f, 0.2f));
    square(vals, {0, 1.5f, 1.0f}, {0, -1, 0}, {1, 0, 0}, 3.0f, r, glm::vec3(0.5f));
    return vals;
}

std::vector<ref::Receiver> sphere(int side) {
    std::vector<ref::Receiver> out;
    for (int i = 0; i < side; ++i)
        for (int j = 0; j < side; ++j) {
            const double theta = std::numbers::pi * (i + 0.5) / side, phi = 2.0 * std::numbers::pi * (j + 0.5) / side;
            ref::Receiver x;
            x.normal = glm::dvec3(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
            x.position = 0.3 * x.normal;
            x.exponent = 20.0;
            out.push_back(x);
        }
    return out;
}

double cpuSeconds() { return double(std::clock()) / CLOCKS_PER_SEC; }

struct Timing {
    double wall = 0.0, cpu = 0.0;
};
template <class F>
Timing timed(F&& f) {
    const auto w0 = std::chrono::steady_clock::now();
    const double c0 = cpuSeconds();
    f();
    return {std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count(), cpuSeconds() - c0};
}

double relativeMse(const std::vector<ref::GatherSums>& a, const std::vector<ref::GatherSums>& b, bool glossy) {
    double num = 0.0, den = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        const glm::dvec3 x = glossy ? a[i].glossy : a[i].irradiance, y = glossy ? b[i].glossy : b[i].irradiance;
        num += glm::dot(x - y, x - y);
        den += glm::dot(y, y);
    }
    return den > 0.0 ? num / den : 0.0;
}

} // namespace

int main(int argc, char** argv) {
    const int side = argc > 1 ? std::atoi(argv[1]) : 16;
    const bool glossy = argc > 2 ? std::atoi(argv[2]) != 0 : true;
    const bool quadtree = argc > 3 && std::atoi(argv[3]) != 0;
    const auto receivers = sphere(side);
    const glm::dvec3 eye(0.0, -2.0, 0.5);
    ref::GatherParameters parameters;
    parameters.glossy = glossy;
    std::printf("# %zu sparse points, glossy %d, %s, CPU time per gather (s), double reference, 1 thread\n",
                receivers.size(), int(glossy), quadtree ? "image quadtree" : "BVH");
    std::printf("| VALs | flat (s) | threshold | build (s) | cut (s) | flat/cut | nodes/point | cut size/point | "
                "relMSE L'_d | relMSE L'_s |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
    for (int r : {67, 134, 270, 358}) {
        const auto vals = room(r);
        std::vector<ref::GatherSums> flat, cut;
        const Timing tFlat = timed([&] { ref::gatherInto(vals, receivers, eye, parameters, flat); });
        gi::ValTreeD tree;
        std::vector<std::uint32_t> keys(vals.size());
        for (std::size_t i = 0; i < keys.size(); ++i) keys[i] = std::uint32_t(i); // row-major in each grid
        const Timing tBuild = timed([&] {
            if (quadtree)
                gi::buildValQuadtreeInto(vals, keys, std::uint32_t(r), std::uint32_t(4 * r), tree);
            else
                gi::buildValTreeInto(vals, tree);
        });
        for (double threshold : {0.0, 0.01, 0.1, 1.0}) {
            ref::CutStatistics stats;
            const Timing tCut = timed([&] {
                ref::gatherWithCutInto(tree, vals, receivers, eye, parameters, threshold, cut, nullptr, &stats);
            });
            const double n = double(receivers.size());
            std::printf("| %zu | %.3f | %g | %.3f | %.3f | %.1f | %.0f | %.0f | %.2e | %.2e |\n", vals.size(),
                        tFlat.cpu, threshold, tBuild.cpu, tCut.cpu, tFlat.cpu / tCut.cpu, double(stats.visited) / n,
                        double(stats.clusters + stats.skipped + stats.leaves) / n, relativeMse(cut, flat, false),
                        relativeMse(cut, flat, true));
            std::fflush(stdout);
        }
    }
    return 0;
}
