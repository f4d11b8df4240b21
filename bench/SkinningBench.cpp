// lightskin_bench_skinning: per-frame CPU cost of deforming a skinned mesh (render/Skinning.h: bone matrices and
// linear blend skinning of positions and normals) and of carrying LightSkin's sparse points along
// (gi::followSurfaceInto, gi::refitOccluderRadiiInto). A separate program, never a test; the numbers go to
// docs/PLUGIN.md with this command:
//   build/bench/lightskin_bench_skinning [repeats=200] [sparsePoints=4096]
// The mesh: tests/data/meshes/bending_cylinder.gltf with its clip, refined (gi::refineMeshToEdgeLength) to several
// sizes; the refined vertices take the sample's weights from its closed form (upper bone w = clamp((y - 0.75) / 0.5)).
// Each time: the median over `repeats` frames at different clip times of this thread's CPU time, single-threaded.
// Then what keeping the occluder radii and neighbours costs in validity at the clip's end (90 degrees): the largest
// ratio of a vertex's distance to its owner point over that point's radius (> 1: the disc no longer reaches it),
// and the share of vertices whose nearest point is no longer their first neighbour.
#include <lightskin/core/CpuTime.h>
#include <lightskin/core/Error.h>
#include <lightskin/gi/common/SparsePointSampler.h>
#include <lightskin/render/MeshLoader.h>
#include <lightskin/render/Skinning.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <limits>
#include <string>
#include <vector>

namespace {

using namespace lightskin;

double medianOf(std::vector<double>& values) {
    std::sort(values.begin(), values.end());
    return values[values.size() / 2];
}

/// The sample's weights by height, for a refined copy (its new vertices are not in the file).
std::vector<render::SkinWeights> weightsByHeight(const TriangleMesh& mesh, const render::SkinnedClip& skin) {
    const std::uint32_t upper = skin.clip.tree.nodes[skin.bones[0].node].name == "Upper" ? 0 : 1;
    std::vector<render::SkinWeights> weights(mesh.vertexCount());
    for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
        const float w = std::clamp((mesh.positions[v].y - 0.75f) / 0.5f, 0.0f, 1.0f);
        render::compactInfluences({{upper, w}, {1 - upper, 1.0f - w}}, weights[v]);
    }
    return weights;
}

struct Validity {
    double radiusRatio = 0.0; ///< max over vertices: distance to their owner point / the owner's kept radius
    double nearestChanged =
        -1.0; ///< % of vertices whose nearest sparse point is another after the bend (-1: not measured)
};

/// The kept sparse data against the deformed mesh: each point's occluder disc must reach the vertices it owns
/// (SparsePointSampler: radius = farthest owned vertex), and each vertex's first neighbour is its nearest point.
Validity keptValidity(const TriangleMesh& deformed, const gi::SparsePointSet& set,
                      const std::vector<gi::SparsePoint>& points) {
    Validity out;
    for (std::size_t v = 0; v < deformed.vertexCount(); ++v) {
        const std::uint32_t owner = set.vertexNeighbours[v][0];
        const double radius = double(set.points[owner].occluderRadius);
        if (radius > 0.0)
            out.radiusRatio =
                std::max(out.radiusRatio, double(glm::length(deformed.positions[v] - points[owner].position)) / radius);
    }
    if (deformed.vertexCount() * points.size() > 300'000'000) return out; // brute force: the small meshes only
    std::size_t changed = 0;
    for (std::size_t v = 0; v < deformed.vertexCount(); ++v) {
        std::size_t nearest = 0;
        float best = std::numeric_limits<float>::infinity();
        for (std::size_t i = 0; i < points.size(); ++i) {
            const glm::vec3 d = deformed.positions[v] - points[i].position;
            if (glm::dot(d, d) < best) best = glm::dot(d, d), nearest = i;
        }
        if (nearest != set.vertexNeighbours[v][0]) ++changed;
    }
    out.nearestChanged = 100.0 * double(changed) / double(deformed.vertexCount());
    return out;
}

void benchSize(const render::LoadedModel& model, const render::SkinnedClip& skin, double maxEdge, int repeats,
               int sparsePoints) {
    TriangleMesh rest = model.parts.at(0).mesh;
    gi::refineMeshToEdgeLength(rest, maxEdge, 4'000'000);
    const std::vector<render::SkinWeights> weights = weightsByHeight(rest, skin);
    gi::SparsePointSettings settings;
    settings.pointCount = sparsePoints;
    settings.refine = false;
    const gi::SparsePointSet set = gi::sampleSparsePoints(rest, settings, "cylinder");
    std::vector<gi::SparsePoint> points = set.points;
    TriangleMesh deformed = rest;
    render::SkinningScratch scratch;
    std::vector<double> skinMs, pointMs, radiusMs;
    for (int frame = 0; frame < repeats; ++frame) {
        const double t = double(frame % 30) / 30.0;
        const double start = threadCpuMs();
        render::boneMatricesInto(skin, t, scratch);
        render::skinPartInto(weights, scratch, rest, deformed);
        const double skinned = threadCpuMs();
        gi::followSurfaceInto(deformed, set.anchors, points);
        const double followed = threadCpuMs();
        gi::refitOccluderRadiiInto(deformed, set.vertexNeighbours, points);
        radiusMs.push_back(threadCpuMs() - followed);
        pointMs.push_back(followed - skinned);
        skinMs.push_back(skinned - start);
    }
    // How far kept occluder radii and neighbours are from what the bent mesh (clip's end, 90 degrees) needs.
    render::boneMatricesInto(skin, 1.0, scratch);
    render::skinPartInto(weights, scratch, rest, deformed);
    points = set.points;
    gi::followSurfaceInto(deformed, set.anchors, points);
    const Validity validity = keptValidity(deformed, set, points);
    char changed[32] = "-";
    if (validity.nearestChanged >= 0.0) std::snprintf(changed, sizeof changed, "%.1f %%", validity.nearestChanged);
    std::printf("| %zu | %zu | %.3f | %d | %.3f | %.3f | %.2f | %s |\n", rest.vertexCount(), rest.triangleCount(),
                medianOf(skinMs), sparsePoints, medianOf(pointMs), medianOf(radiusMs), validity.radiusRatio, changed);
}

} // namespace

int main(int argc, char** argv) {
    try {
        const int repeats = argc > 1 ? std::max(1, std::atoi(argv[1])) : 200;
        const int sparsePoints = argc > 2 ? std::max(16, std::atoi(argv[2])) : 4096;
        const std::string file = std::string(LIGHTSKIN_TEST_DATA_DIR) + "/meshes/bending_cylinder.gltf";
        const render::LoadedModel model = render::loadModel(file);
        const render::SkinnedClip skin = render::loadSkinnedClip(file, {}, model);
        std::printf("| vertices | triangles | skinning ms | sparse points | point update ms | radius refit ms | owner "
                    "distance / kept radius at 90 deg | vertices whose nearest point changed |\n"
                    "|---|---|---|---|---|---|---|---|\n");
        for (const double maxEdge : {1.0, 0.05, 0.0125, 0.005}) benchSize(model, skin, maxEdge, repeats, sparsePoints);
    } catch (const lightskin::Error& error) {
        std::fprintf(stderr, "%s\n", error.what());
        return 1;
    }
    return 0;
}
