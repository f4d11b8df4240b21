#include "AssimpAnimation.h"
#include "MeshFileChecks.h"

#include <lightskin/core/Error.h>
#include <lightskin/render/GltfAnimation.h>

#include <assimp/postprocess.h>

#include <algorithm>
#include <cmath>
#include <string>

namespace lightskin::render {

namespace detail {

glm::mat4 toGlm(const aiMatrix4x4& m) {
    glm::mat4 out; // assimp stores rows, glm columns
    for (unsigned row = 0; row < 4; ++row)
        for (unsigned col = 0; col < 4; ++col) out[int(col)][int(row)] = m[row][col];
    return out;
}

const aiScene& importForAnimation(const std::filesystem::path& file, Assimp::Importer& importer) {
    checkBeforeImport(file, importer);
    const aiScene* scene = importer.ReadFile(file.string(), aiProcess_ValidateDataStructure);
    if (scene == nullptr || scene->mRootNode == nullptr)
        throw Error(file.string(), std::nullopt,
                    std::string("cannot read the file's nodes and animations (assimp: ") + importer.GetErrorString() +
                        ")");
    if (scene->mNumAnimations == 0)
        throw Error(file.string(), std::nullopt, "the file has no animation (\"animation\": \"gltf\" plays one)");
    return *scene;
}

namespace {

std::string clipList(const aiScene& scene) {
    std::string list;
    for (unsigned i = 0; i < scene.mNumAnimations; ++i)
        list += (i ? ", " : "") + std::to_string(i) + " '" + scene.mAnimations[i]->mName.C_Str() + "'";
    return list;
}

} // namespace

std::size_t chooseClip(const aiScene& scene, const ClipChoice& choice, const std::filesystem::path& file) {
    if (const auto* index = std::get_if<std::size_t>(&choice.clip)) {
        if (*index < scene.mNumAnimations) return *index;
        throw Error(file.string(), std::nullopt,
                    "no clip " + std::to_string(*index) + " (the file's clips: " + clipList(scene) + ")");
    }
    if (const auto* name = std::get_if<std::string>(&choice.clip)) {
        for (unsigned i = 0; i < scene.mNumAnimations; ++i)
            if (*name == scene.mAnimations[i]->mName.C_Str()) return i;
        throw Error(file.string(), std::nullopt,
                    "no clip named '" + *name + "' (the file's clips: " + clipList(scene) + ")");
    }
    return 0;
}

std::vector<const aiNode*> chainTo(const aiNode* node) {
    std::vector<const aiNode*> chain;
    for (; node != nullptr; node = node->mParent) chain.push_back(node);
    std::reverse(chain.begin(), chain.end());
    return chain;
}

namespace {

/// Validates one key list and hands each key, converted to seconds, to `add`.
template <class Key, class Add>
void readKeys(const Key* keys, unsigned count, double ticksPerSecond, const std::string& where, Add add) {
    double previous = -1.0;
    for (unsigned k = 0; k < count; ++k) {
        const std::string key = where + " key " + std::to_string(k);
        const double t = keys[k].mTime / ticksPerSecond;
        if (!std::isfinite(t) || t < 0.0) throw Error(key + ": the time must be finite and >= 0");
        if (!(t > previous)) throw Error(key + ": the time must be after the previous key's (increasing)");
        previous = t;
        add(t, keys[k].mValue, key);
    }
}

bool finite(const aiVector3D& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

/// The merged keys of one channel: every time of its position, rotation and scale keys, each value interpolated
/// from its own keys (a list without keys holds the rest pose's value).
TransformAnimation mergeChannel(const TransformAnimation& translation, const TransformAnimation& rotation,
                                const TransformAnimation& scale) {
    std::vector<double> times;
    for (const TransformAnimation* list : {&translation, &rotation, &scale})
        for (const TransformKey& key : list->keys) times.push_back(key.timeSeconds);
    std::sort(times.begin(), times.end());
    times.erase(std::unique(times.begin(), times.end()), times.end());
    TransformAnimation merged;
    for (const double t : times)
        merged.keys.push_back({.timeSeconds = t,
                               .translation = sampleTransformKey(translation, t).translation,
                               .rotation = sampleTransformKey(rotation, t).rotation,
                               .scale = sampleTransformKey(scale, t).scale});
    return merged;
}

/// A node channel as parent_T_node over clip seconds. Throws lightskin::Error (source: `where`) on bad keys.
TransformAnimation readChannel(const aiNodeAnim& channel, const aiNode& node, double ticksPerSecond,
                               const std::string& where) {
    aiVector3D restScale, restPosition;
    aiQuaternion restRotation;
    node.mTransformation.Decompose(restScale, restRotation, restPosition);
    TransformAnimation translation, rotation, scale;
    readKeys(channel.mPositionKeys, channel.mNumPositionKeys, ticksPerSecond, where + " position",
             [&](double t, const aiVector3D& v, const std::string& key) {
                 if (!finite(v)) throw Error(key + ": a non-finite translation");
                 translation.keys.push_back({.timeSeconds = t, .translation = {v.x, v.y, v.z}});
             });
    readKeys(channel.mRotationKeys, channel.mNumRotationKeys, ticksPerSecond, where + " rotation",
             [&](double t, const aiQuaternion& q, const std::string& key) {
                 const glm::quat r(q.w, q.x, q.y, q.z);
                 const float length = glm::length(r);
                 if (!std::isfinite(length) || length < 1e-6f) throw Error(key + ": a non-finite or zero rotation");
                 rotation.keys.push_back({.timeSeconds = t, .rotation = r / length});
             });
    readKeys(channel.mScalingKeys, channel.mNumScalingKeys, ticksPerSecond, where + " scale",
             [&](double t, const aiVector3D& s, const std::string& key) {
                 if (!finite(s)) throw Error(key + ": a non-finite scale");
                 // Placements are rotation x one uniform scale; 1e-5 relative is float rounding of equal values.
                 const float mean = (s.x + s.y + s.z) / 3.0f;
                 if (!(mean > 0.0f) || std::abs(s.x - mean) > 1e-5f * mean || std::abs(s.y - mean) > 1e-5f * mean ||
                     std::abs(s.z - mean) > 1e-5f * mean)
                     throw Error(key + ": a scale that is not uniform and > 0 (placements are rotation x one scale)");
                 scale.keys.push_back({.timeSeconds = t, .scale = mean});
             });
    if (translation.keys.empty())
        translation.keys.push_back({.translation = {restPosition.x, restPosition.y, restPosition.z}});
    if (rotation.keys.empty())
        rotation.keys.push_back(
            {.rotation = glm::quat(restRotation.w, restRotation.x, restRotation.y, restRotation.z)});
    if (scale.keys.empty()) {
        const float mean = (restScale.x + restScale.y + restScale.z) / 3.0f;
        if (std::abs(restScale.x - mean) > 1e-5f * mean || std::abs(restScale.y - mean) > 1e-5f * mean ||
            std::abs(restScale.z - mean) > 1e-5f * mean)
            throw Error(where + ": the node's rest scale is not uniform (placements are rotation x one scale)");
        scale.keys.push_back({.scale = mean});
    }
    return mergeChannel(translation, rotation, scale);
}

} // namespace

NodeClip readNodeClip(const aiScene& scene, std::size_t clipIndex, const std::vector<const aiNode*>& nodes,
                      const std::filesystem::path& file, std::vector<std::string>& unusedChannels) {
    const aiAnimation& animation = *scene.mAnimations[clipIndex];
    NodeClip clip;
    clip.file = file;
    clip.name = animation.mName.C_Str();
    clip.index = clipIndex;
    const std::string clipName = "clip " + std::to_string(clipIndex) + " '" + clip.name + "'";
    // assimp documents 0 ticks per second as "not specified", to be read as 25.
    const double ticksPerSecond = animation.mTicksPerSecond != 0.0 ? animation.mTicksPerSecond : 25.0;
    if (!std::isfinite(ticksPerSecond) || ticksPerSecond < 0.0)
        throw Error(file.string(), std::nullopt, clipName + ": ticks per second must be finite and > 0");
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        const auto parent = std::find(nodes.begin(), nodes.end(), nodes[i]->mParent);
        AnimatedNodeTree::Node& node = clip.tree.nodes.emplace_back();
        node.name = nodes[i]->mName.C_Str();
        node.parent = parent == nodes.end() ? -1 : int(parent - nodes.begin());
        node.parent_T_node = toGlm(nodes[i]->mTransformation);
    }
    for (unsigned c = 0; c < animation.mNumChannels; ++c) {
        const aiNodeAnim& channel = *animation.mChannels[c];
        const std::string nodeName = channel.mNodeName.C_Str();
        const auto node =
            std::find_if(nodes.begin(), nodes.end(), [&](const aiNode* n) { return nodeName == n->mName.C_Str(); });
        if (node == nodes.end()) {
            unusedChannels.push_back(nodeName);
            continue;
        }
        const std::string where = clipName + ", channel " + std::to_string(c) + " (node '" + nodeName + "')";
        try {
            TransformAnimation keys = readChannel(channel, **node, ticksPerSecond, where);
            clip.durationSeconds = std::max(clip.durationSeconds, keys.keys.back().timeSeconds);
            clip.tree.nodes[std::size_t(node - nodes.begin())].animation = std::move(keys);
        } catch (const Error& error) {
            throw Error(file.string(), std::nullopt, error.cause());
        }
    }
    return clip;
}

} // namespace detail

void poseInto(const AnimatedNodeTree& tree, double clipSeconds, std::vector<glm::mat4>& out) {
    out.resize(tree.nodes.size());
    for (std::size_t i = 0; i < tree.nodes.size(); ++i) {
        const AnimatedNodeTree::Node& node = tree.nodes[i];
        const glm::mat4 local = node.animation ? sampleTransform(*node.animation, clipSeconds) : node.parent_T_node;
        LIGHTSKIN_ASSERT(node.parent < int(i), "parents must come before their children");
        out[i] = node.parent < 0 ? local : out[std::size_t(node.parent)] * local;
    }
}

double clipTime(const NodeClip& clip, bool loop, double timeSeconds) {
    if (!std::isfinite(timeSeconds) || timeSeconds <= 0.0) return 0.0;
    if (!loop || !(clip.durationSeconds > 0.0)) return timeSeconds;
    return std::fmod(timeSeconds, clip.durationSeconds);
}

glm::mat4 sampleRigidClip(const RigidClip& clip, double clipSeconds) {
    glm::mat4 file_T_node(1.0f);
    for (const AnimatedNodeTree::Node& node : clip.clip.tree.nodes)
        file_T_node =
            file_T_node * (node.animation ? sampleTransform(*node.animation, clipSeconds) : node.parent_T_node);
    return file_T_node * clip.rest_T_file;
}

namespace {

void collectMeshNodes(const aiNode* node, std::vector<const aiNode*>& out) {
    if (node->mNumMeshes > 0) out.push_back(node);
    for (unsigned i = 0; i < node->mNumChildren; ++i) collectMeshNodes(node->mChildren[i], out);
}

/// Rotation x one uniform scale (no shear, no stretch), to float rounding of composed rotations (1e-4 relative).
bool rotationTimesUniformScale(const glm::mat4& m) {
    const glm::vec3 x(m[0]), y(m[1]), z(m[2]);
    const float s = (glm::length(x) + glm::length(y) + glm::length(z)) / 3.0f;
    constexpr float kTolerance = 1e-4f;
    return s > 0.0f && std::abs(glm::length(x) - s) <= kTolerance * s &&
           std::abs(glm::length(y) - s) <= kTolerance * s && std::abs(glm::length(z) - s) <= kTolerance * s &&
           std::abs(glm::dot(x, y)) <= kTolerance * s * s && std::abs(glm::dot(x, z)) <= kTolerance * s * s &&
           std::abs(glm::dot(y, z)) <= kTolerance * s * s;
}

/// The motion file_T_mesh(t) file_T_mesh(rest)^-1 is P N(t) N(rest)^-1 P^-1, P the nodes above the lowest animated
/// one: a rotation x uniform scale only when P is one too (a stretched P turns the clip's rotation into a shear).
void checkAncestorsAreRigid(const NodeClip& clip, const std::string& source) {
    const auto& nodes = clip.tree.nodes;
    const auto lowest =
        std::find_if(nodes.rbegin(), nodes.rend(), [](const auto& n) { return n.animation.has_value(); });
    if (lowest == nodes.rend()) return;
    for (auto above = std::next(lowest); above != nodes.rend(); ++above)
        if (!rotationTimesUniformScale(above->parent_T_node))
            throw Error(source, std::nullopt,
                        "node '" + above->name + "' above the animated node '" + lowest->name +
                            "' has a shear or a non-uniform scale: the clip's motion would not be a rotation x one "
                            "uniform scale");
}

} // namespace

RigidClip loadRigidClip(const std::filesystem::path& file, const ClipChoice& choice) {
    Assimp::Importer importer;
    const aiScene& scene = detail::importForAnimation(file, importer);
    const std::string source = file.string();
    for (unsigned m = 0; m < scene.mNumMeshes; ++m)
        if (scene.mMeshes[m]->HasBones())
            throw Error(source, std::nullopt,
                        "mesh " + std::to_string(m) + " '" + scene.mMeshes[m]->mName.C_Str() + "' is skinned (" +
                            std::to_string(scene.mMeshes[m]->mNumBones) +
                            " bones): its clip deforms it (loadSkinnedClip), it is no rigid motion");
    std::vector<const aiNode*> meshNodes;
    collectMeshNodes(scene.mRootNode, meshNodes);
    if (meshNodes.empty()) throw Error(source, std::nullopt, "no node carries a mesh");
    const std::size_t index = detail::chooseClip(scene, choice, file);
    std::vector<std::string> unused;
    RigidClip rigid;
    rigid.clip = detail::readNodeClip(scene, index, detail::chainTo(meshNodes.front()), file, unused);
    // Every mesh moves with the one chain only when the animated nodes are above all of them.
    for (const aiNode* meshNode : meshNodes) {
        const std::vector<const aiNode*> chain = detail::chainTo(meshNode);
        for (const AnimatedNodeTree::Node& node : rigid.clip.tree.nodes)
            if (node.animation && std::none_of(chain.begin(), chain.end(),
                                               [&](const aiNode* n) { return node.name == n->mName.C_Str(); }))
                unused.push_back(node.name);
    }
    if (!unused.empty())
        throw Error(source, std::nullopt,
                    "clip " + std::to_string(index) + " '" + rigid.clip.name + "' animates node '" + unused.front() +
                        "', which is not above every mesh of the file (meshes moving apart are not played)");
    checkAncestorsAreRigid(rigid.clip, source);
    glm::mat4 file_T_mesh(1.0f);
    for (const AnimatedNodeTree::Node& node : rigid.clip.tree.nodes) file_T_mesh = file_T_mesh * node.parent_T_node;
    rigid.rest_T_file = glm::inverse(file_T_mesh);
    return rigid;
}

glm::mat4 sampleGltfAnimation(const GltfObjectAnimation& animation, double timeSeconds) {
    return animation.world_T_file *
           sampleRigidClip(animation.rigid, clipTime(animation.rigid.clip, animation.loop, timeSeconds));
}

} // namespace lightskin::render
