#pragma once
// What GltfAnimation.cpp and Skinning.cpp share in reading assimp's animations (private to render/).

#include <lightskin/render/GltfAnimation.h>

#include <assimp/Importer.hpp>
#include <assimp/scene.h>

#include <filesystem>
#include <vector>

namespace lightskin::render::detail {

glm::mat4 toGlm(const aiMatrix4x4& m);

/// The file with its node tree (no pre-transform, no repairs), after MeshFileChecks' checks. Throws
/// lightskin::Error naming the file when it cannot be read or has no animation. The scene lives in `importer`.
const aiScene& importForAnimation(const std::filesystem::path& file, Assimp::Importer& importer);

/// The chosen clip's index. Throws lightskin::Error naming the file and the clip (listing the clips) when unknown.
std::size_t chooseClip(const aiScene& scene, const ClipChoice& choice, const std::filesystem::path& file);

/// The clip over `nodes` (parents before children; each node's parent, if any, among them or the tree's root is
/// above all of them): rest poses, and the channels of the clip that target them, validated (Error naming the file,
/// clip, node, channel and key). Channels of other nodes are left out; `unusedChannels` gets their node names.
NodeClip readNodeClip(const aiScene& scene, std::size_t clipIndex, const std::vector<const aiNode*>& nodes,
                      const std::filesystem::path& file, std::vector<std::string>& unusedChannels);

/// The node and its ancestors, root first.
std::vector<const aiNode*> chainTo(const aiNode* node);

} // namespace lightskin::render::detail
