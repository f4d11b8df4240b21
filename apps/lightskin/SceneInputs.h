#pragma once
// The files a loaded scene reads besides itself (meshes, textures, the tag world file, the
// multi-scale PRT cache): inputs that no output folder may be, hold or lie inside (CliSupport.h).
#include "CliSupport.h"

#include <lightskin/render/Scene.h>

#include <nlohmann/json.hpp>

namespace lightskin::apps {

inline InputPaths sceneInputs(const render::Scene& scene) {
    InputPaths inputs{scene.file};
    for (const render::SceneObject& object : scene.objects) {
        inputs.push_back(object.mesh);
        if (object.material.diffuseTexture) inputs.push_back(*object.material.diffuseTexture);
    }
    if (!scene.gi.multiscalePrt.cacheDirectory.empty()) inputs.push_back(scene.gi.multiscalePrt.cacheDirectory);
    const nlohmann::json tracking = nlohmann::json::parse(scene.trackingJson, nullptr, false);
    if (tracking.is_object() && tracking.contains("file") && tracking["file"].is_string())
        inputs.push_back(scene.file.parent_path() / tracking["file"].get<std::string>());
    return inputs;
}

} // namespace lightskin::apps
