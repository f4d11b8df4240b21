#pragma once
// The description of a synthetic RGB-D scene and its camera path, as read from a JSON file
// (format "lightskin-synth-scene", version 1; every field is documented in docs/SYNTH.md).
//
// Frames and units: the world is right-handed, z up, metres; the room is the box
// [0, size.x] x [0, size.y] x [0, size.z] with the floor at z = 0. Colours and albedos are linear
// RGB. Light power is radiant power in watts per colour channel (an RGB "spectrum": the
// channel values are what a renderer of RGB radiance sums), radiance is W m^-2 sr^-1.
// Camera frames follow OpenCV (x right, y down, z forward), as everywhere in lightskin.

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace lightskin::synth {

/// Orientation of a flat thing (tag, board, area light) given by the direction its visible face
/// looks at ("facing", the outward normal) and the direction of its top edge ("up"). Both world
/// directions; `up` is made orthogonal to `facing`.
struct Placement {
    glm::dvec3 position{0.0};         ///< centre, world metres
    glm::dvec3 facing{0.0, 0.0, 1.0}; ///< outward normal of the visible face
    glm::dvec3 up{0.0, 1.0, 0.0};     ///< direction of the top edge of the face

    /// world_T_face with the face frame x right, y up (as the face is seen from the front),
    /// z = facing (out of the surface): lightskin's tag frame (tracking/TagFamily.h, as OpenCV's
    /// ArUco), origin at `position`.
    Pose world_T_face() const;
};

struct RoomDescription {
    glm::dvec3 size{4.0, 3.5, 2.6}; ///< metres, x (west->east), y (south->north), z (floor->ceiling)
    /// Diffuse albedo (linear RGB) of each inner face.
    glm::vec3 floorAlbedo{0.55f, 0.5f, 0.45f};
    glm::vec3 ceilingAlbedo{0.8f};
    glm::vec3 westAlbedo{0.7f};  ///< wall at x = 0
    glm::vec3 eastAlbedo{0.7f};  ///< wall at x = size.x
    glm::vec3 southAlbedo{0.7f}; ///< wall at y = 0
    glm::vec3 northAlbedo{0.7f}; ///< wall at y = size.y
};

/// A box resting anywhere (a table, a cupboard), rotated about the world z axis.
struct BoxDescription {
    std::string name;
    glm::dvec3 center{0.0};  ///< world metres
    glm::dvec3 size{1.0};    ///< full edge lengths, metres
    double yawDegrees = 0.0; ///< rotation about world z
    glm::vec3 albedo{0.6f};
};

enum class LightType { Point, Area };

struct LightDescription {
    LightType type = LightType::Point;
    /// Point: an isotropic point, radiant intensity I = P / (4 pi) W/sr per channel. Not visible itself.
    /// Area: a one-sided Lambertian rectangle, radiance L_e = P / (pi * width * height), drawn as
    /// an emitting panel; shading integrates it with samples x samples point samples (midpoint rule).
    Placement placement;         ///< Point uses placement.position only
    glm::dvec2 size{0.5, 0.5};   ///< Area: width (along the face's x) and height, metres
    glm::vec3 powerWatts{40.0f}; ///< radiant power per RGB channel
    int samples = 4;             ///< Area: samples per side (1..8)
};

/// One AprilTag: `size` is the edge length of its black border (the AprilTag convention); the
/// white quiet zone around it is drawn too. placement.position is the tag centre.
struct TagDescription {
    std::string family = "tag36h11";
    int id = 0;
    double sizeMetres = 0.16;
    Placement placement;
};

/// A planar grid of tags (a "bundle"): ids firstId, firstId+1, ... row by row from the top-left
/// (as seen from the front), centres `spacingMetres` apart.
struct TagBoardDescription {
    std::string family = "tag36h11";
    int firstId = 0;
    int rows = 2, columns = 2;
    double sizeMetres = 0.08;
    double spacingMetres = 0.12;
    Placement placement; ///< centre of the grid
    /// The individual tags, in world coordinates.
    std::vector<TagDescription> expand() const;
};

enum class PathSegmentType { Orbit, Linear, Pan, Hold };

/// One piece of the camera path, `frames` frames long, covering parameter t = i / frames,
/// i = 0..frames-1 (the end is the next segment's start).
struct PathSegment {
    PathSegmentType type = PathSegmentType::Hold;
    int frames = 1;
    bool smooth = false; ///< ease in/out (smoothstep of t) instead of constant speed
    // Orbit: the camera circles `center` at `radius` (horizontal) and height `height` (world z),
    // azimuth from startDegrees to endDegrees (0 = camera on the +x side of the centre, 90 = +y),
    // looking at `target`.
    glm::dvec3 center{0.0};
    double radius = 1.5;
    double height = 1.4;
    double startDegrees = 0.0, endDegrees = 90.0;
    // Linear and Hold: position and target move from `from*` to `to*` (Hold uses from* only).
    // Orbit uses `target` (= fromTarget).
    glm::dvec3 fromPosition{0.0}, fromTarget{0.0, 1.0, 0.0};
    glm::dvec3 toPosition{0.0}, toTarget{0.0, 1.0, 0.0};
    // Pan: fixed position (fromPosition), yaw about world z from startDegrees to endDegrees
    // (0 = looking along +x, 90 = +y), pitch `pitchDegrees` (negative looks down).
    double pitchDegrees = 0.0;
};

/// Hand-held-like shake added on top of the path: per axis a sum of three sinusoids of seeded
/// random frequency (0.4-3 Hz) and phase, scaled so each axis has the given standard deviation.
/// Translation in world metres, rotation a small rotation about the camera axes.
struct ShakeDescription {
    double translationStdMetres = 0.0;
    double rotationStdDegrees = 0.0;
    std::uint64_t seed = 1;
};

struct CameraPathDescription {
    double fps = 30.0;
    std::vector<PathSegment> segments;
    ShakeDescription shake;
    int frameCount() const noexcept;
};

/// Kinect v1-like depth noise; see DepthNoise.h for the model and its sources.
struct DepthNoiseDescription {
    bool enabled = false;
    std::uint64_t seed = 1;
    double minRangeMetres = 0.5, maxRangeMetres = 4.0; ///< outside: 0 (missing)
    double baselineMetres = 0.075;     ///< IR projector to IR camera, along the camera x axis
    double sensorFocalPixels = 580.0;  ///< focal length of the IR camera (disparity units)
    double disparitySubpixel = 8.0;    ///< disparity is quantised to 1/this pixel
    bool axialNoise = true;            ///< Nguyen et al. 2012 sigma_z(z)
    bool lateralNoise = true;          ///< Nguyen et al. 2012 sigma_L(theta) at depth edges
    bool projectorShadow = true;       ///< holes where the projector does not see the surface
    double grazingStartDegrees = 70.0; ///< dropout probability rises from 0 here ...
    double grazingEndDegrees = 82.0;   ///< ... to 1 here (angle between surface normal and view ray)
    double edgeDropoutProbability = 0.5; ///< chance a pixel next to a depth jump is missing
    double edgeJumpRelative = 0.05;    ///< a depth jump: |dz| > this * z between 4-neighbours
};

struct SceneDescription {
    std::string name = "scene";
    std::filesystem::path sourcePath; ///< the file it was read from, or the name given to parseSceneDescription

    RoomDescription room;
    std::vector<BoxDescription> boxes;
    std::vector<LightDescription> lights;
    glm::vec3 ambientRadiance{0.0f}; ///< uniform incident radiance added as albedo * L_a (W m^-2 sr^-1)
    std::vector<TagDescription> tags; ///< single tags and the expanded boards
    float tagBlackAlbedo = 0.04f, tagWhiteAlbedo = 0.85f;

    CameraIntrinsics intrinsics = CameraIntrinsics::kinectV1Default().scaledTo(320, 240);
    double nearMetres = 0.05, farMetres = 20.0; ///< rasterisation clip planes
    CameraPathDescription path;

    /// Linear pixel value = exposure * radiance (W m^-2 sr^-1), then clamped to [0,1] and
    /// sRGB-encoded to 8 bits.
    double exposure = 1.0;
    /// Colour is the mean of s^2 samples per pixel (a box filter over the pixel, in linear space),
    /// on an n-rooks lattice so that edges are resolved in 1/s^2 px steps.
    int supersampling = 3;
    double depthScaleMetres = 0.001; ///< metres per 16-bit depth unit
    DepthNoiseDescription noise;

    bool writeNormals = false;   ///< exact world normals per pixel (float images)
    bool writePositions = false; ///< exact world positions per pixel (float images)
    bool writeRadiance = false;  ///< linear radiance before exposure and 8-bit encoding (float images)

    /// Throws lightskin::Error naming the source and the bad field.
    void validate() const;
};

/// Parses a description; `sourceName` names it in errors. Throws lightskin::Error.
SceneDescription parseSceneDescription(const std::string& jsonText, const std::string& sourceName);
/// Reads and parses a description file. Throws lightskin::Error.
SceneDescription loadSceneDescription(const std::filesystem::path& path);

/// world_T_camera of frame `frameIndex` (0-based, < path.frameCount()), shake included.
Pose cameraPoseAt(const CameraPathDescription& path, int frameIndex);

/// A camera at `position` looking at `target`, world z up, no roll (OpenCV camera frame).
Pose lookAt(const glm::dvec3& position, const glm::dvec3& target);

} // namespace lightskin::synth
