#pragma once
// Scene files: what virtual content to place in the tracked world, how to light it and how to
// run GI and tracking. One JSON format, documented in docs/SCENE_FORMAT.md (version 1).
//
// Frames and units: positions in the world frame (the AprilTag/bundle frame or the recording's
// ground-truth frame), metres; angles in degrees in the file, radians nowhere in this API; light
// power in watts (radiant flux, linear RGB). Mesh and texture paths are relative to the scene file.
//
// Validation happens on load: every error is a lightskin::Error whose source is the scene file and
// whose cause starts with the JSON pointer of the offending key (e.g. /objects/0/material/specularExponent)
// and says what was expected. Unknown keys are errors too (typos would otherwise be silently ignored),
// except inside "tracking", which is passed to the tracking module as it is.

#include <lightskin/gi/ImperfectVolumes.h>
#include <lightskin/gi/MultiscalePrt.h>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lightskin::render {

struct MaterialOverride {
    std::optional<glm::vec3> diffuseAlbedo;  ///< linear RGB in [0,1]
    std::optional<glm::vec3> specularAlbedo; ///< linear RGB in [0,1]
    std::optional<float> specularExponent;   ///< >= 1
    std::optional<std::filesystem::path> diffuseTexture; ///< absolute after loading
};

struct SceneObject {
    std::string name;
    std::filesystem::path mesh;     ///< absolute after loading (relative in the file)
    glm::mat4 world_T_model{1.0f};  ///< translation * rotation * uniform scale
    MaterialOverride material;      ///< applied to every part of the mesh
};

enum class LightType { Point, Spot };

struct SceneLight {
    LightType type = LightType::Point;
    glm::vec3 position{0.0f};              ///< world, metres
    glm::vec3 direction{0.0f, 0.0f, -1.0f}; ///< unit, world (spot lights)
    glm::vec3 power{10.0f};                ///< radiant flux, watts, linear RGB (emitted into the full sphere for a point light)
    float coneAngleDegrees = 30.0f;        ///< spot: half angle of full intensity ...
    float coneFalloffDegrees = 5.0f;       ///< ... then a smooth falloff to zero over this many degrees
    bool castsShadows = true;
    /// The light is really in the room (the scene's copy of a room light): its light is in the
    /// camera image already, so the differential composite only darkens the real surfaces by the
    /// virtual objects' shadow. false: a purely virtual light, whose (shadowed) light the
    /// differential adds to the real surfaces too.
    bool inRoom = true;
};

struct GiSettings {
    std::string technique =
        "lightskin"; ///< "lightskin", "brute-force", "imperfect-volumes", "multiscale-prt" or "none"
    /// Where LightSkin's stages 0-4 run: "gl" (gi::LightSkinIllumination) or "cpu"
    /// (gi::CpuLightSkin: SIMD + threads on the CPU; shading stays on GL). Only for "lightskin".
    std::string backend = "gl";
    int sparsePoints = 4096;             ///< sparse scene points per mesh (paper: 4k or 16k)
    int valStride = 4;                   ///< one VAL per valStride x valStride depth pixels
    int kCache = 128;                    ///< the paper's K_cache (VALs per cache block)
    bool diffuse = true;
    bool glossy = true;
    bool occlusion = true;
    /// One bounce between virtual objects: per frame, a reflective shadow map of the virtual
    /// meshes per scene light gives VALs (gi::ReflectiveShadowMap) that are merged after the
    /// depth VALs. Off by default: opt-in, so existing scenes keep their images and frame times.
    bool virtualBounce = false;
    int rsmResolution = 64;              ///< RSM texels per side per light face (spot: 1 face, point: 6)
    /// Frame-time budget in milliseconds ("budgetMs"; 0 = none): a mr::Session then picks technique,
    /// sparse points, VAL stride and channels per frame to meet it (mr/FrameBudget.h).
    double budgetMs = 0.0;
    /// The light model for real depth (docs/BENCHMARKS.md "Indirect light on real depth"):
    /// on by default; false = the model before it, for measurement (`lightskin bench-realdepth`).
    bool robustRealDepth = true;
    /// LightSkin's gather with a cut through the VAL tree (gi::LightSkinSettings::valTreeThreshold,
    /// both backends): 0 = the flat gather over every VAL (the default).
    float valTreeThreshold = 0.0f;
    /// Not a scene key: with robustRealDepth, false drops only its vertex irradiance cap (guard G10)
    /// for measurement (`lightskin bench-realdepth --models robust-nocap`).
    bool robustIrradianceCap = true;
    /// Not a scene key: with robustRealDepth, false drops only its rule for sparse points buried under the
    /// real surface (guard G11) for measurement (`lightskin bench-realdepth --models robust-noburied`).
    bool robustBuriedSparsePoints = true;
    /// Not a scene key: with robustRealDepth, true adds near-field VALs as areas (guard G12:
    /// gi::LightSkinSettings::nearFieldArea, gi::BruteForceSettings::nearFieldArea; `lightskin
    /// bench-realdepth --models robust-area`). Off by default for now: on llvmpipe the polygon's loop
    /// inside the per-VAL loop makes the gather ~3x and the brute force ~4x slower even where no VAL is
    /// near (docs/bench/history/real-depth.md "Near-field VALs as areas"), for no measured gain in speckle on the
    /// bundled real recordings.
    bool robustNearField = false;
    /// Technique "imperfect-volumes" (gi/ImperfectVolumes.h): the "imperfectVolumes" object.
    gi::ImperfectVolumesSettings imperfectVolumes;
    /// Technique "multiscale-prt" (gi/MultiscalePrt.h): the "multiscalePrt" object. Its cacheDirectory is
    /// "prt-cache" beside the scene file unless the scene says otherwise (empty for scenes parsed from text).
    gi::MultiscalePrtSettings multiscalePrt;
};

struct CompositeSettings {
    /// Soft occlusion band half-width in multiples of the Kinect axial noise sigma_z(z)
    /// (see render/Compositor.h); and its lower bound in metres.
    float softBandSigmas = 3.0f;
    float minSoftBandMetres = 0.005f;
    /// Differential rendering (gi/DifferentialIrradiance.h, render::applyDifferentialInto): the
    /// virtual objects' shadows and reflected light on the real surfaces around them.
    bool differential = true;
};

struct Scene {
    std::filesystem::path file; ///< the scene file (empty when parsed from text)
    std::vector<SceneObject> objects;
    std::vector<SceneLight> lights;
    GiSettings gi;
    CompositeSettings compositing;
    /// Exposure in stops: displayed = sRGB(clamp(2^exposureStops * L_linear, 0, 1)).
    float exposureStops = 0.0f;
    /// The "tracking" object as JSON text ("{}" when absent), handed to the tracking module.
    std::string trackingJson = "{}";
};

/// Reads and validates a scene file. Mesh paths are resolved against the file's folder and must exist.
Scene loadScene(const std::filesystem::path& path);

/// Parses scene JSON text. `baseFolder` resolves relative paths; `sourceName` names the text in errors.
Scene parseScene(std::string_view text, const std::filesystem::path& baseFolder, const std::string& sourceName);

/// Reads a float 4x4 from Euler angles (degrees, applied about x, then y, then z: R = Rz * Ry * Rx),
/// translation (metres) and uniform scale.
glm::mat4 composeTransform(const glm::vec3& translation, const glm::vec3& rotationDegrees, float scale);

} // namespace lightskin::render
