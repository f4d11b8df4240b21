#pragma once
// The animations stored in mesh files (glTF 2.0, read through assimp's aiAnimation node channels): a clip moves
// nodes of the file's node tree; the meshes on those nodes follow rigidly (this header), and skinned meshes
// deform with their bone nodes (render/Skinning.h). Scene format: docs/SCENE_FORMAT.md, "Animation".
//
// Frames: file space = the file's root frame, in the file's units read as metres (what loadModel's vertices are
// in: it bakes the node transforms of the rest pose into them). Time: clip seconds = the file's key times
// (ticks / mTicksPerSecond; assimp's default of 25 ticks per second when the file gives 0).
//
// Interpolation reuses render/Animation.h's: per node, translation and scale linearly, rotation by slerp along
// the shorter arc; a channel's keys at other times (position, rotation and scale keys have their own times) are
// resampled at the union of the times, which leaves the piecewise linear/slerp curves unchanged. glTF's STEP and
// CUBICSPLINE samplers reach us as assimp's keys and play linearly.

#include <lightskin/render/Animation.h>

#include <glm/mat4x4.hpp>

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace lightskin::render {

/// The nodes a clip needs, parents before children. Owns its data (no assimp objects kept).
struct AnimatedNodeTree {
    struct Node {
        std::string name;
        int parent = -1;                             ///< index into nodes, -1 for the root
        glm::mat4 parent_T_node{1.0f};               ///< the rest pose (the file's node transform)
        std::optional<TransformAnimation> animation; ///< parent_T_node over clip time; loop false
    };
    std::vector<Node> nodes;
};

/// file_T_node of every node at `clipSeconds` into `out` (resized to nodes.size(); no allocation once sized).
/// An unanimated node keeps its rest pose; an animated one holds its first/last key outside its keys.
void poseInto(const AnimatedNodeTree& tree, double clipSeconds, std::vector<glm::mat4>& out);

/// One clip of a file: the node tree it animates and its length.
struct NodeClip {
    std::filesystem::path file;
    std::string name;             ///< the clip's name in the file (may be empty)
    std::size_t index = 0;        ///< the clip's index in the file
    double durationSeconds = 0.0; ///< the last key's time over every channel (the loop's period), >= 0
    AnimatedNodeTree tree;
};

/// The clip's time for scene time `timeSeconds` (seconds from the first frame): the same, or with `loop` (and a
/// duration > 0) wrapped into [0, duration).
double clipTime(const NodeClip& clip, bool loop, double timeSeconds);

/// A rigid clip: the motion of the file's (unskinned) meshes. Every animated node is an ancestor of (or is) every
/// mesh node, so all meshes move together: model_T_model(t) = file_T_mesh(t) * file_T_mesh(rest)^-1, which maps
/// loadModel's vertices (rest pose, file space) to their place at clip time t.
struct RigidClip {
    NodeClip clip;               ///< clip.tree: the chain from the root down to a mesh node, one node per level
    glm::mat4 rest_T_file{1.0f}; ///< file_T_mesh(rest)^-1
};
/// model_T_model at `clipSeconds` (see above). No allocation: a product along the chain.
glm::mat4 sampleRigidClip(const RigidClip& clip, double clipSeconds);

/// Which clip of a file: by name, by index, or (neither) the first.
struct ClipChoice {
    std::variant<std::monostate, std::string, std::size_t> clip;
};

/// Reads the chosen clip for rigid playback. Throws lightskin::Error naming the file (and the clip, node, channel
/// and key) when: the file cannot be read, has no animation, the clip is unknown, a key is non-finite, negative
/// in time or out of order, a scale key is not uniform (placements are rotation x uniform scale), a node above the
/// animated ones is sheared or stretched (the motion would shear), an animated node is not above every mesh
/// (per-mesh motion is not played), or a mesh is skinned (its clip deforms it: loadSkinnedClip, Skinning.h).
RigidClip loadRigidClip(const std::filesystem::path& file, const ClipChoice& choice);

/// The scene's `"animation": "gltf"` on an object: world_T_model(t) = world_T_file * model_T_model(clip time),
/// world_T_file being the object's `transform` (the file's motion happens inside the object's placement).
struct GltfObjectAnimation {
    RigidClip rigid;
    bool loop = false;
    glm::mat4 world_T_file{1.0f};
};
glm::mat4 sampleGltfAnimation(const GltfObjectAnimation& animation, double timeSeconds);

} // namespace lightskin::render
