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

#include <lightskin/gi/Techniques.h>
#include <lightskin/render/Animation.h>
#include <lightskin/render/GltfAnimation.h>

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

/// Which clip of a skinned mesh file deforms it, and whether it loops (as GltfObjectAnimation's).
struct GltfSkinAnimation {
    ClipChoice clip;
    bool loop = false;
};

struct SceneObject {
    std::string name;
    std::filesystem::path mesh;     ///< absolute after loading (relative in the file)
    glm::mat4 world_T_model{1.0f};  ///< translation * rotation * uniform scale (the first key's when animated)
    MaterialOverride material;      ///< applied to every part of the mesh
    /// Keyframes: the placement follows them (render/Animation.h); unset = world_T_model at all times.
    std::optional<TransformAnimation> animation;
    /// `"animation": "gltf"`: the mesh file's clip inside the object's `transform` (render/GltfAnimation.h);
    /// unset = none.
    std::optional<GltfObjectAnimation> gltfAnimation;
    /// `"animation": "gltf"` on a skinned mesh file: the clip deforms the mesh (render/Skinning.h) inside
    /// world_T_model, which stays the object's `transform`; unset = none. Played by the renderer (Renderer::deformAt).
    std::optional<GltfSkinAnimation> skinAnimation;
    bool visible = true; ///< drawn, lit and lighting; false = as if absent (kept loaded)
};

/// True when the object changes over time: its placement follows an animation (scene keys or a glTF clip) or a
/// clip deforms its mesh.
bool isAnimated(const SceneObject& object);
/// The object's world_T_model at `timeSeconds` (seconds from the first frame): its animation's, or world_T_model.
glm::mat4 placementAt(const SceneObject& object, double timeSeconds);

/// Estimated: the real room's dominant light as the roomlight estimator finds it every frame (mr::FramePipeline
/// sets its position and power per frame; a point light for the renderer and the GI techniques).
enum class LightType { Point, Spot, Estimated };

/// A light of type Estimated: how the room's light is estimated and turned into the virtual objects' direct light
/// (docs/ROOMLIGHT.md, "In the pipeline"). Defaults are the measured trade-off of cost and lag.
struct EstimatedLightSettings {
    /// Every stride-th pixel in x and y is a sample (roomlight::RoomLightOptions::stride). Cost ~ 1 / stride^2.
    int stride = 8;
    /// One fit every fitInterval frames; between fits the last filtered estimate stays (the filter's time
    /// constant is 0.25 s, so a fit per 100 ms at 30 Hz loses little). Cost per frame ~ 1 / fitInterval.
    int fitInterval = 3;
    /// Time constant of the estimate's temporal filter, seconds (roomlight::RoomLightOptions::timeConstantSeconds).
    double timeConstantSeconds = 0.25;
    /// Albedo the room's most common surface colour is taken to have (roomlight::RoomLightOptions::referenceAlbedo):
    /// the one assumption that sets the estimate's absolute level (a brighter room than assumed looks lit more).
    double referenceAlbedo = 0.5;
    /// A distant dominant light (no position, or farther than this from the objects) is drawn as a point light
    /// at this distance along its direction, its power scaled so its irradiance at the objects' centre is the
    /// estimate's. Metres. Trade-off: nearer, the irradiance varies over an object of radius r by ~ +-2 r / d;
    /// farther, the cube shadow map's texels (and its bias, 0.01 + 0.02 d m) grow with d.
    float distantLightMetres = 5.0f;
};

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
    /// Keyframes of position, direction and power (render/Animation.h; the values above are then the first
    /// key's); unset = the values above at all times.
    std::optional<LightAnimation> animation;
    /// type Estimated only: the estimator's settings (position and power above are then set every frame).
    EstimatedLightSettings estimation;
};

/// The scene's "gi" object: the technique registry's settings (lightskin/gi/Techniques.h).
using GiSettings = gi::GiSettings;

struct CompositeSettings {
    /// Soft occlusion band half-width in multiples of the Kinect axial noise sigma_z(z)
    /// (see render/Compositor.h); and its lower bound in metres.
    float softBandSigmas = 3.0f;
    float minSoftBandMetres = 0.005f;
    /// Differential rendering (gi/differential/DifferentialIrradiance.h, render::applyDifferentialInto): the
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
    /// The "roomModel" object as JSON text (empty when absent: no room memory), handed to the roommodel module.
    std::string roomModelJson;
};

/// Reads and validates a scene file. Mesh paths are resolved against the file's folder and must exist.
Scene loadScene(const std::filesystem::path& path);

/// Parses scene JSON text. `baseFolder` resolves relative paths; `sourceName` names the text in errors.
Scene parseScene(std::string_view text, const std::filesystem::path& baseFolder, const std::string& sourceName);

/// Reads a float 4x4 from Euler angles (degrees, applied about x, then y, then z: R = Rz * Ry * Rx),
/// translation (metres) and uniform scale.
glm::mat4 composeTransform(const glm::vec3& translation, const glm::vec3& rotationDegrees, float scale);

} // namespace lightskin::render
