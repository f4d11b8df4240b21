#include "AssimpAnimation.h"
#include "MeshFileChecks.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/render/Skinning.h>

#include <assimp/postprocess.h>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string>

namespace lightskin::render {

std::size_t compactInfluences(std::vector<BoneInfluence> influences, SkinWeights& out) {
    out = SkinWeights{};
    std::erase_if(influences, [](const BoneInfluence& i) { return !(std::isfinite(i.weight) && i.weight > 0.0f); });
    std::sort(influences.begin(), influences.end(),
              [](const BoneInfluence& a, const BoneInfluence& b) { return a.weight > b.weight; });
    const std::size_t kept = std::min(influences.size(), kMaxInfluences);
    float sum = 0.0f;
    for (std::size_t k = 0; k < kept; ++k) sum += influences[k].weight;
    for (std::size_t k = 0; k < kept; ++k) {
        out.bones[k] = influences[k].bone;
        out.weights[k] = influences[k].weight / sum;
    }
    return influences.size() - kept;
}

namespace {

using PositionKey = std::array<float, 3>; // -0 and +0 compare equal under <, as they should

void collectNodes(const aiNode* node, const std::set<const aiNode*>& needed, std::vector<const aiNode*>& out) {
    if (needed.count(node) != 0) out.push_back(node); // depth first: parents before children
    for (unsigned i = 0; i < node->mNumChildren; ++i) collectNodes(node->mChildren[i], needed, out);
}

const aiNode* nodeOfMesh(const aiNode* node, unsigned mesh) {
    for (unsigned i = 0; i < node->mNumMeshes; ++i)
        if (node->mMeshes[i] == mesh) return node;
    for (unsigned i = 0; i < node->mNumChildren; ++i)
        if (const aiNode* found = nodeOfMesh(node->mChildren[i], mesh)) return found;
    return nullptr;
}

bool isIdentity(const glm::mat4& m) {
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r)
            if (std::abs(m[c][r] - (c == r ? 1.0f : 0.0f)) > 1e-6f) return false;
    return true;
}

/// The bone nodes and their ancestors, parents first. Throws when a bone names no node.
std::vector<const aiNode*> boneNodes(const aiScene& scene, const std::string& source) {
    std::set<const aiNode*> needed;
    for (unsigned m = 0; m < scene.mNumMeshes; ++m)
        for (unsigned b = 0; b < scene.mMeshes[m]->mNumBones; ++b) {
            const aiBone& bone = *scene.mMeshes[m]->mBones[b];
            const aiNode* node = scene.mRootNode->FindNode(bone.mName);
            if (node == nullptr)
                throw Error(source, std::nullopt,
                            std::string("bone '") + bone.mName.C_Str() + "' of mesh " + std::to_string(m) +
                                " names no node of the file");
            for (const aiNode* n : detail::chainTo(node)) needed.insert(n);
        }
    std::vector<const aiNode*> ordered;
    collectNodes(scene.mRootNode, needed, ordered);
    return ordered;
}

/// The skinned meshes' weights by rest position (file space), their bones appended to `skin.bones`.
std::map<PositionKey, SkinWeights> weightsByPosition(const aiScene& scene, const std::vector<const aiNode*>& nodes,
                                                     SkinnedClip& skin, const std::string& source) {
    std::map<PositionKey, SkinWeights> byPosition;
    for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
        const aiMesh& mesh = *scene.mMeshes[m];
        if (!mesh.HasBones()) continue;
        const std::string where = "mesh " + std::to_string(m) + " '" + mesh.mName.C_Str() + "'";
        const aiNode* meshNode = nodeOfMesh(scene.mRootNode, m);
        glm::mat4 file_T_mesh(1.0f);
        for (const aiNode* n : detail::chainTo(meshNode)) file_T_mesh = file_T_mesh * detail::toGlm(n->mTransformation);
        if (meshNode == nullptr || !isIdentity(file_T_mesh))
            throw Error(source, std::nullopt,
                        where + ": a skinned mesh's node must sit at the file's root frame (identity transform)");
        const auto firstBone = std::uint32_t(skin.bones.size());
        std::vector<std::vector<BoneInfluence>> influences(mesh.mNumVertices);
        for (unsigned b = 0; b < mesh.mNumBones; ++b) {
            const aiBone& bone = *mesh.mBones[b];
            const aiNode* node = scene.mRootNode->FindNode(bone.mName);
            skin.bones.push_back({.node = std::size_t(std::find(nodes.begin(), nodes.end(), node) - nodes.begin()),
                                  .bone_T_rest = detail::toGlm(bone.mOffsetMatrix)});
            for (unsigned w = 0; w < bone.mNumWeights; ++w)
                if (bone.mWeights[w].mVertexId < mesh.mNumVertices)
                    influences[bone.mWeights[w].mVertexId].push_back({firstBone + b, bone.mWeights[w].mWeight});
        }
        for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
            SkinWeights weights;
            if (compactInfluences(std::move(influences[v]), weights) > 0) ++skin.verticesWithDroppedInfluences;
            if (weights.weights[0] == 0.0f)
                throw Error(source, std::nullopt, where + ": vertex " + std::to_string(v) + " has no bone weight > 0");
            byPosition.emplace(PositionKey{mesh.mVertices[v].x, mesh.mVertices[v].y, mesh.mVertices[v].z}, weights);
        }
    }
    if (byPosition.empty()) throw Error(source, std::nullopt, "no mesh of the file is skinned");
    return byPosition;
}

} // namespace

bool hasSkin(const std::filesystem::path& file) {
    Assimp::Importer importer;
    checkBeforeImport(file, importer);
    const aiScene* scene = importer.ReadFile(file.string(), aiProcess_ValidateDataStructure);
    if (scene == nullptr)
        throw Error(file.string(), std::nullopt,
                    std::string("cannot read the file's meshes (assimp: ") + importer.GetErrorString() + ")");
    return std::any_of(scene->mMeshes, scene->mMeshes + scene->mNumMeshes,
                       [](const aiMesh* m) { return m->HasBones(); });
}

void checkSkinnedClip(const std::filesystem::path& file, const ClipChoice& choice) {
    Assimp::Importer importer;
    (void)detail::chooseClip(detail::importForAnimation(file, importer), choice, file);
}

SkinnedClip loadSkinnedClip(const std::filesystem::path& file, const ClipChoice& choice, const LoadedModel& model) {
    Assimp::Importer importer;
    const aiScene& scene = detail::importForAnimation(file, importer);
    const std::string source = file.string();
    if (std::none_of(scene.mMeshes, scene.mMeshes + scene.mNumMeshes, [](const aiMesh* m) { return m->HasBones(); }))
        throw Error(source, std::nullopt, "no mesh of the file is skinned");
    const std::size_t index = detail::chooseClip(scene, choice, file);
    const std::vector<const aiNode*> nodes = boneNodes(scene, source);
    SkinnedClip skin;
    std::vector<std::string> unused;
    skin.clip = detail::readNodeClip(scene, index, nodes, file, unused);
    if (!unused.empty())
        throw Error(source, std::nullopt,
                    "clip " + std::to_string(index) + " '" + skin.clip.name + "' animates node '" + unused.front() +
                        "', which is no bone nor above one (rigid motion of a skinned file is not played)");
    const std::map<PositionKey, SkinWeights> byPosition = weightsByPosition(scene, nodes, skin, source);
    for (std::size_t p = 0; p < model.parts.size(); ++p) {
        const TriangleMesh& mesh = model.parts[p].mesh;
        std::vector<SkinWeights>& weights = skin.parts.emplace_back(mesh.vertexCount());
        for (std::size_t v = 0; v < mesh.vertexCount(); ++v) {
            const glm::vec3& q = mesh.positions[v];
            const auto found = byPosition.find(PositionKey{q.x, q.y, q.z});
            if (found == byPosition.end())
                throw Error(source, std::nullopt,
                            "part " + std::to_string(p) + " vertex " + std::to_string(v) +
                                " matches no skinned vertex (every mesh of a skinned file must be skinned)");
            weights[v] = found->second;
        }
    }
    if (skin.verticesWithDroppedInfluences > 0)
        log::warning(source + ": " + std::to_string(skin.verticesWithDroppedInfluences) +
                     " vertices have more than 4 bone influences; the 4 largest are kept, renormalised");
    return skin;
}

void boneMatricesInto(const SkinnedClip& skin, double clipSeconds, SkinningScratch& scratch) {
    poseInto(skin.clip.tree, clipSeconds, scratch.pose);
    scratch.bones.resize(skin.bones.size());
    scratch.boneNormals.resize(skin.bones.size());
    for (std::size_t i = 0; i < skin.bones.size(); ++i) {
        scratch.bones[i] = scratch.pose[skin.bones[i].node] * skin.bones[i].bone_T_rest;
        scratch.boneNormals[i] = glm::transpose(glm::inverse(glm::mat3(scratch.bones[i])));
    }
}

void skinPartInto(std::span<const SkinWeights> weights, const SkinningScratch& matrices, const TriangleMesh& rest,
                  TriangleMesh& out) {
    LIGHTSKIN_ASSERT(weights.size() == rest.vertexCount() && out.positions.size() == rest.vertexCount() &&
                         out.normals.size() == rest.vertexCount(),
                     "weights, rest and out must have the same vertex count");
    for (std::size_t v = 0; v < rest.vertexCount(); ++v) {
        const glm::vec4 p(rest.positions[v], 1.0f);
        glm::vec3 position(0.0f), normal(0.0f);
        for (std::size_t k = 0; k < kMaxInfluences; ++k) {
            const float w = weights[v].weights[k];
            if (w == 0.0f) break; // compactInfluences puts the weights first, largest first
            position += w * glm::vec3(matrices.bones[weights[v].bones[k]] * p);
            normal += w * (matrices.boneNormals[weights[v].bones[k]] * rest.normals[v]);
        }
        out.positions[v] = position;
        const float length = glm::length(normal);
        // Opposite bones can cancel a normal (a fold): the rest normal is the better guess than none.
        out.normals[v] = length > 1e-12f ? normal / length : rest.normals[v];
    }
}

} // namespace lightskin::render
