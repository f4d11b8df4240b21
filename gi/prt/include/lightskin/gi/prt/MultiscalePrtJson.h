#pragma once
// Multi-scale PRT's settings from the scene's "gi"/"multiscalePrt" object (docs/SCENE_FORMAT.md).

#include <lightskin/core/JsonReader.h>
#include <lightskin/gi/prt/MultiscalePrt.h>

#include <string>

namespace lightskin::gi {

/// Ranges as validate(MultiscalePrtSettings) checks them; an error names the key under `pointer`. The cache
/// folder is resolved against reader.baseFolder() (the scene's folder): by default "prt-cache" beside the
/// scene, none when the base folder is empty.
MultiscalePrtSettings readMultiscalePrtSettings(const JsonReader& reader, const nlohmann::json& value,
                                                const std::string& pointer);

} // namespace lightskin::gi
