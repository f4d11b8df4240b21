#pragma once
// Imperfect volumes' settings from the scene's "gi"/"imperfectVolumes" object (docs/SCENE_FORMAT.md).

#include <lightskin/core/JsonReader.h>
#include <lightskin/gi/volumes/ImperfectVolumes.h>

#include <string>

namespace lightskin::gi {

/// Ranges as validate(ImperfectVolumesSettings) checks them; an error names the key under `pointer`.
ImperfectVolumesSettings readImperfectVolumesSettings(const JsonReader& reader, const nlohmann::json& value,
                                                      const std::string& pointer);

} // namespace lightskin::gi
