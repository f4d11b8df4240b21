#pragma once
// Skinned meshes (glTF 2.0 skins through assimp's aiMesh::mBones): linear blend skinning of loadModel's vertices
// by the bone nodes of a clip (render/GltfAnimation.h), on the CPU, per frame, into buffers sized once.
//
// Frames: the rest (bind) pose is loadModel's vertices in file space (metres). A bone's offset matrix (glTF's
// inverse bind matrix) maps them into the bone's frame; file_T_bone(t) maps back at clip time t:
//   p(t) = sum_i w_i M_i(t) p_rest,   M_i(t) = file_T_bone_i(t) * bone_T_rest_i,
//   n(t) = normalize(sum_i w_i N_i(t) n_rest),   N_i = inverse transpose of M_i's upper 3x3.
// The skinned mesh's own node must sit at the file's root frame (identity rest transform; glTF 2.0 ignores that
// node's transform for skinned meshes, and loadModel would have baked it into the rest pose).
//
// Influences: up to 4 per vertex (the 4 largest when the file has more; counted in SkinnedClip and logged),
// weights renormalised to sum 1. A vertex of a skinned mesh without any weight is an error.

#include <lightskin/core/TriangleMesh.h>
#include <lightskin/render/GltfAnimation.h>
#include <lightskin/render/MeshLoader.h>

#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

namespace lightskin::render {

inline constexpr std::size_t kMaxInfluences = 4;

/// A vertex's bones (indices into SkinnedClip::bones) and weights (sum 1; unused slots weigh 0 and name bone 0).
struct SkinWeights {
    std::array<std::uint32_t, kMaxInfluences> bones{};
    std::array<float, kMaxInfluences> weights{};
};

struct BoneInfluence {
    std::uint32_t bone = 0;
    float weight = 0.0f;
};

/// The 4 largest of `influences` (weights > 0 and finite; others are ignored), renormalised to sum 1, into `out`.
/// Returns how many positive influences were dropped beyond the 4; `out` stays all zero when none is positive.
std::size_t compactInfluences(std::vector<BoneInfluence> influences, SkinWeights& out);

struct Bone {
    std::size_t node = 0;        ///< index into SkinnedClip::clip.tree.nodes
    glm::mat4 bone_T_rest{1.0f}; ///< the offset (inverse bind) matrix: file space rest pose -> bone frame
};

/// A file's skin and the clip that moves its bones.
struct SkinnedClip {
    NodeClip clip; ///< the bone nodes and their ancestors
    std::vector<Bone> bones;
    std::vector<std::vector<SkinWeights>> parts;   ///< per loadModel part, per vertex
    std::size_t verticesWithDroppedInfluences = 0; ///< vertices that had more than 4 influences
};

/// Reads the chosen clip and the skin of `file`, matching its vertices to `model`'s (loadModel(file): repaired,
/// re-indexed) by their rest position. Throws lightskin::Error naming the file when: anything loadRigidClip
/// refuses (but for the skin), no mesh is skinned, a skinned mesh's node is not at the root frame, a bone names
/// no node, a vertex has no weight, or a vertex of `model` matches no skinned vertex.
SkinnedClip loadSkinnedClip(const std::filesystem::path& file, const ClipChoice& choice, const LoadedModel& model);

/// True when a mesh of `file` has bones. Throws lightskin::Error naming the file when it cannot be read.
bool hasSkin(const std::filesystem::path& file);

/// Throws lightskin::Error naming the file when it has no animation or the chosen clip is unknown.
void checkSkinnedClip(const std::filesystem::path& file, const ClipChoice& choice);

/// Per-frame working memory, sized by the first call (no allocation afterwards).
struct SkinningScratch {
    std::vector<glm::mat4> pose;        ///< file_T_node
    std::vector<glm::mat4> bones;       ///< M_i
    std::vector<glm::mat3> boneNormals; ///< N_i
};

/// The bone matrices M_i and N_i at `clipSeconds` into `scratch`.
void boneMatricesInto(const SkinnedClip& skin, double clipSeconds, SkinningScratch& scratch);

/// Skins one part: positions and normals of `out` (sized like `rest`; its indices and texture coordinates are left
/// alone) from `rest` by `weights` and the matrices of boneMatricesInto. No allocation.
void skinPartInto(std::span<const SkinWeights> weights, const SkinningScratch& matrices, const TriangleMesh& rest,
                  TriangleMesh& out);

} // namespace lightskin::render
