// lightskin_bench_skinning: per-frame CPU cost of deforming a skinned mesh (render/Skinning.h: bone matrices and
// linear blend skinning of positions and normals) and of carrying LightSkin's sparse points along
// (gi::followSurfaceInto). A separate program, never a test; the numbers go to docs/PLUGIN.md with this command:
//   build/bench/lightskin_bench_skinning [repeats=200] [sparsePoints=4096]
// The mesh: tests/data/meshes/bending_cylinder.gltf with its clip, refined (gi::refineMeshToEdgeLength) to several
// sizes; the refined vertices take the sample's weights from its closed form (upper bone w = clamp((y - 0.75) / 0.5)).
// Each number: the median over `repeats` frames at different clip times of this thread's CPU time, single-threaded.
#include <lightskin/core/Error.h>
#include <lightskin/gi/common/SparsePointSampler.h>
#include <lightskin/render/MeshLoader.h>
#include <lightskin/render/Skinning.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

namespace {

using namespace lightskin;

double medianOf(std::vector<double>& values) {
    std::sort(values.begin(), values.end());
    return values[values.size() / 2];
}

// CPU time of this thread: the machine is shared, and wall time would count the other processes' turns.
double threadMilliseconds() {
    timespec now{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
    return static_cast<double>(now.tv_sec) * 1e3 + static_cast<double>(now.tv_nsec) * 1e-6;
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
    std::vector<double> skinMs, pointMs;
    for (int frame = 0; frame < repeats; ++frame) {
        const double t = double(frame % 30) / 30.0;
        const double start = threadMilliseconds();
        render::boneMatricesInto(skin, t, scratch);
        render::skinPartInto(weights, scratch, rest, deformed);
        const double skinned = threadMilliseconds();
        gi::followSurfaceInto(deformed, set.anchors, points);
        pointMs.push_back(threadMilliseconds() - skinned);
        skinMs.push_back(skinned - start);
    }
    std::printf("| %zu | %zu | %.3f | %d | %.3f |\n", rest.vertexCount(), rest.triangleCount(), medianOf(skinMs),
                sparsePoints, medianOf(pointMs));
}

} // namespace

int main(int argc, char** argv) {
    try {
        const int repeats = argc > 1 ? std::max(1, std::atoi(argv[1])) : 200;
        const int sparsePoints = argc > 2 ? std::max(16, std::atoi(argv[2])) : 4096;
        const std::string file = std::string(LIGHTSKIN_TEST_DATA_DIR) + "/meshes/bending_cylinder.gltf";
        const render::LoadedModel model = render::loadModel(file);
        const render::SkinnedClip skin = render::loadSkinnedClip(file, {}, model);
        std::printf(
            "| vertices | triangles | skinning ms | sparse points | point update ms |\n|---|---|---|---|---|\n");
        for (const double maxEdge : {1.0, 0.05, 0.0125, 0.005}) benchSize(model, skin, maxEdge, repeats, sparsePoints);
    } catch (const lightskin::Error& error) {
        std::fprintf(stderr, "%s\n", error.what());
        return 1;
    }
    return 0;
}
