// Fuzz target: scene JSON text through render::parseScene (in memory). The base folder holds an
// existing mesh.obj and texture.png, so object and material paths can pass the existence check.
#include "FuzzSupport.h"

#include <lightskin/core/Error.h>
#include <lightskin/render/Scene.h>

#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const lightskin::fuzz::ScratchFolder folder("scene");
    static const bool filesWritten = [] {
        lightskin::fuzz::writeFile(folder.path() / "mesh.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
        lightskin::fuzz::writeFile(folder.path() / "texture.png", "not read by parseScene");
        return true;
    }();
    (void)filesWritten;
    try {
        (void)lightskin::render::parseScene(std::string_view(reinterpret_cast<const char*>(data), size), folder.path(),
                                            "fuzz-scene.json");
    } catch (const lightskin::Error&) {
    }
    return 0;
}
