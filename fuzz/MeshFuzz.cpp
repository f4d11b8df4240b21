// Fuzz target: mesh files through render::loadModel (our checks and repairs over assimp), then, for a file it
// reads, through the readers of its animation and skin (render::loadRigidClip, render::loadSkinnedClip). The
// first input byte picks what the rest becomes (modulo 6): an .obj, a .ply, a .gltf, a .glb, the
// .mtl of a fixed OBJ that uses it, or the .bin buffer of a fixed glTF triangle.
#include "FuzzSupport.h"

#include <lightskin/core/Error.h>
#include <lightskin/render/GltfAnimation.h>
#include <lightskin/render/MeshLoader.h>
#include <lightskin/render/Skinning.h>

#include <array>

namespace {

constexpr const char* kObjUsingMtl = "mtllib fuzz.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
// A triangle whose positions are in buffer.bin (36 bytes: three float vec3).
constexpr const char* kGltfUsingBin =
    R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],)"
    R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],)"
    R"("buffers":[{"uri":"buffer.bin","byteLength":36}],"bufferViews":[{"buffer":0,"byteLength":36}],)"
    R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}]})";

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    static const lightskin::fuzz::ScratchFolder folder("mesh");
    const auto& root = folder.path();
    const auto* rest = data + 1;
    const std::size_t restSize = size - 1;
    std::filesystem::path model;
    switch (data[0] % 6) {
    case 0:
        model = root / "fuzz.obj";
        break;
    case 1:
        model = root / "fuzz.ply";
        break;
    case 2:
        model = root / "fuzz.gltf";
        break;
    case 3:
        model = root / "fuzz.glb";
        break;
    case 4:
        model = root / "uses-mtl.obj";
        lightskin::fuzz::writeFile(model, kObjUsingMtl);
        lightskin::fuzz::writeFile(root / "fuzz.mtl", rest, restSize);
        break;
    default:
        model = root / "uses-bin.gltf";
        lightskin::fuzz::writeFile(model, kGltfUsingBin);
        lightskin::fuzz::writeFile(root / "buffer.bin", rest, restSize);
        break;
    }
    if (data[0] % 6 < 4) lightskin::fuzz::writeFile(model, rest, restSize);
    lightskin::render::LoadedModel loaded;
    try {
        loaded = lightskin::render::loadModel(model);
    } catch (const lightskin::Error&) {
        return 0;
    }
    try {
        (void)lightskin::render::loadRigidClip(model, {});
    } catch (const lightskin::Error&) {
    }
    try {
        (void)lightskin::render::loadSkinnedClip(model, {}, loaded);
    } catch (const lightskin::Error&) {
    }
    return 0;
}
