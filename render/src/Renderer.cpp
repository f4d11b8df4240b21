#include "EmbeddedShaders.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/ImageFile.h>
#include <lightskin/core/Log.h>
#include <lightskin/gi/common/SparsePointSampler.h>
#include <lightskin/gl/DebugOutput.h>
#include <lightskin/gl/Readback.h>
#include <lightskin/gl/ShaderLibrary.h>
#include <lightskin/gl/TextureUpload.h>
#include <lightskin/render/CameraProjection.h>
#include <lightskin/render/MeshLoader.h>
#include <lightskin/render/Renderer.h>
#include <lightskin/render/Skinning.h>

#include <glm/common.hpp>
#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

namespace lightskin::render {

struct Renderer::Object {
    TriangleMesh mesh;
    GpuMesh gpu;
    Material material;
    Material ownMaterial; ///< the mesh file's (and the scene's texture), before the scene's or host's override
    glm::mat4 world_T_model{1.0f};
    bool visible = true;
    glm::vec3 modelMin{0.0f}, modelMax{0.0f}; ///< the mesh's bounding box, model frame
    gl::Texture texture; ///< empty when the material has none
    std::optional<gi::SparsePointSet> sparse;
    /// A skinned part: its clip (shared by the object's parts), its part index there, its rest pose, and the
    /// skinning's working memory (sized on the first frame).
    struct Skin {
        std::shared_ptr<const SkinnedClip> clip;
        std::size_t part = 0;
        bool loop = false;
        TriangleMesh rest;
        SkinningScratch scratch;
    };
    std::optional<Skin> skin;
};

namespace {

constexpr int kMaxLights = 4;

gl::Texture loadTexture(const std::string& path) {
    // Through the PNG/TIFF/JPEG guard: a scene's texture is untrusted input like a recording.
    const cv::Mat image = readImageFile(path, cv::IMREAD_COLOR);
    cv::Mat rgba;
    cv::cvtColor(image, rgba, cv::COLOR_BGR2RGBA);
    cv::flip(rgba, rgba, 0); // texture coordinate v = 0 is the bottom row (OBJ/glTF after assimp)
    return gl::createMipmappedRepeatingTexture2D(GL_SRGB8_ALPHA8, rgba.cols, rgba.rows, GL_RGBA, GL_UNSIGNED_BYTE,
                                                 rgba.data);
}

void setMat4(const gl::Program& program, const char* name, const glm::mat4& m) {
    glProgramUniformMatrix4fv(program.id(), program.uniformLocation(name), 1, GL_FALSE, glm::value_ptr(m));
}

} // namespace

const char* toString(DebugView view) noexcept {
    switch (view) {
    case DebugView::Final: return "final";
    case DebugView::DirectOnly: return "direct";
    case DebugView::IndirectOnly: return "indirect";
    case DebugView::Normals: return "normals";
    case DebugView::Albedo: return "albedo";
    }
    return "?";
}

Renderer::~Renderer() = default;

std::unique_ptr<Renderer> Renderer::create(const CameraIntrinsics& intrinsics, const RendererOptions& options) {
    if (!intrinsics.isValid()) throw Error("renderer", std::nullopt, "invalid camera intrinsics " + intrinsics.describe());
    std::unique_ptr<Renderer> r(new Renderer());
    r->intrinsics_ = intrinsics;
    r->options_ = options;
    const gl::ShaderLibrary library{embeddedShaders()};
    r->gbufferProgram_ = library.buildProgram({{GL_VERTEX_SHADER, "gbuffer.vert"}, {GL_FRAGMENT_SHADER, "gbuffer.frag"}});
    r->shadowProgram_ = library.buildProgram({{GL_VERTEX_SHADER, "shadow.vert"}, {GL_FRAGMENT_SHADER, "shadow.frag"}});
    r->shadeProgram_ = library.buildProgram({{GL_VERTEX_SHADER, "fullscreen.vert"}, {GL_FRAGMENT_SHADER, "shade.frag"}});

    const int w = intrinsics.width, h = intrinsics.height;
    r->worldPosition_ = gl::Texture::create2D(GL_RGBA32F, w, h);
    r->worldNormal_ = gl::Texture::create2D(GL_RGBA16F, w, h);
    r->diffuseAlbedo_ = gl::Texture::create2D(GL_RGBA8, w, h);
    r->specular_ = gl::Texture::create2D(GL_RGBA16F, w, h);
    r->depth_ = gl::Texture::create2D(GL_DEPTH_COMPONENT32F, w, h);
    r->indirect_ = gl::Texture::create2D(GL_RGBA32F, w, h);
    r->gbufferFramebuffer_ = gl::Framebuffer::create();
    r->gbufferFramebuffer_.attach(GL_COLOR_ATTACHMENT0, r->worldPosition_);
    r->gbufferFramebuffer_.attach(GL_COLOR_ATTACHMENT1, r->worldNormal_);
    r->gbufferFramebuffer_.attach(GL_COLOR_ATTACHMENT2, r->diffuseAlbedo_);
    r->gbufferFramebuffer_.attach(GL_COLOR_ATTACHMENT3, r->specular_);
    r->gbufferFramebuffer_.attach(GL_DEPTH_ATTACHMENT, r->depth_);
    const GLenum gbufferTargets[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2, GL_COLOR_ATTACHMENT3};
    glNamedFramebufferDrawBuffers(r->gbufferFramebuffer_.id(), 4, gbufferTargets);
    r->gbufferFramebuffer_.checkComplete("G-buffer");
    r->gbufferView_ = {r->worldPosition_.id(), r->worldNormal_.id(), r->diffuseAlbedo_.id(), r->specular_.id(), r->depth_.id(), w, h};

    r->outputColour_ = gl::Texture::create2D(GL_RGBA8, w, h);
    r->outputDepth_ = gl::Texture::create2D(GL_R32F, w, h);
    r->outputFramebuffer_ = gl::Framebuffer::create();
    r->outputFramebuffer_.attach(GL_COLOR_ATTACHMENT0, r->outputColour_);
    r->outputLinear_ = gl::Texture::create2D(GL_RGBA32F, w, h);
    r->outputFramebuffer_.attach(GL_COLOR_ATTACHMENT1, r->outputDepth_);
    r->outputFramebuffer_.attach(GL_COLOR_ATTACHMENT2, r->outputLinear_);
    const GLenum outputTargets[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
    glNamedFramebufferDrawBuffers(r->outputFramebuffer_.id(), 3, outputTargets);
    r->outputFramebuffer_.checkComplete("renderer output");

    const int s = options.shadowMapSize;
    GLuint cubes = 0;
    glCreateTextures(GL_TEXTURE_CUBE_MAP_ARRAY, 1, &cubes);
    glTextureStorage3D(cubes, 1, GL_R32F, s, s, 6 * kMaxLights);
    glTextureParameteri(cubes, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(cubes, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    r->shadowCubes_ = gl::Texture::wrap(cubes, s, s);
    r->shadowDepth_ = gl::Renderbuffer::create(GL_DEPTH_COMPONENT32F, s, s);
    r->shadowFramebuffer_ = gl::Framebuffer::create();
    r->shadowFramebuffer_.attach(GL_DEPTH_ATTACHMENT, r->shadowDepth_);
    glNamedFramebufferTextureLayer(r->shadowFramebuffer_.id(), GL_COLOR_ATTACHMENT0, cubes, 0, 0);
    r->shadowFramebuffer_.checkComplete("shadow maps");

    r->emptyVertexArray_ = gl::VertexArray::create();
    const std::uint8_t white[4] = {255, 255, 255, 255};
    r->whiteTexture_ = gl::Texture::create2D(GL_SRGB8_ALPHA8, 1, 1);
    glTextureSubImage2D(r->whiteTexture_.id(), 0, 0, 0, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, white);
    // Texture storage starts undefined: the first clears cover everything.
    r->gbufferWritten_ = r->outputWritten_ = r->linearWritten_ = glm::ivec4(0, 0, w, h);
    r->timer_ = gl::GpuStageTimer::create(8);
    gl::DebugOutput::throwIfErrors("renderer creation");
    return r;
}

const gi::SparsePointSet* Renderer::sparsePoints(std::uint32_t meshId) const noexcept {
    if (meshId >= objects_.size() || !objects_[meshId]->sparse) return nullptr;
    return &*objects_[meshId]->sparse;
}

namespace {

void applyOverride(const MaterialOverride& o, Material& m) {
    if (o.diffuseAlbedo) m.diffuseAlbedo = *o.diffuseAlbedo;
    if (o.specularAlbedo) m.specularAlbedo = *o.specularAlbedo;
    if (o.specularExponent) m.specularExponent = *o.specularExponent;
}

} // namespace

std::vector<std::unique_ptr<Renderer::Object>> Renderer::loadParts(const SceneObject& so, const std::string& source,
                                                                   const std::string& pointer) {
    LoadedModel model;
    try {
        model = loadModel(so.mesh);
    } catch (const Error& error) {
        throw Error(source, std::nullopt, pointer + " ('" + so.name + "'): " + error.what());
    }
    if (const std::string warning = openBoundaryWarning(so.mesh.string(), model.report);
        !warning.empty() && std::find(warnedOpen_.begin(), warnedOpen_.end(), so.mesh) == warnedOpen_.end()) {
        log::warning(warning); // once per model file, however many objects use it
        warnedOpen_.push_back(so.mesh);
    }
    std::shared_ptr<const SkinnedClip> skin;
    if (so.skinAnimation) {
        try {
            skin = std::make_shared<const SkinnedClip>(loadSkinnedClip(so.mesh, so.skinAnimation->clip, model));
        } catch (const Error& error) {
            throw Error(source, std::nullopt, pointer + " ('" + so.name + "'): " + error.what());
        }
    }
    double totalArea = 0.0;
    for (const MeshPart& part : model.parts) totalArea += gi::surfaceArea(part.mesh);
    std::vector<std::unique_ptr<Object>> parts;
    for (std::size_t partIndex = 0; partIndex < model.parts.size(); ++partIndex) {
        MeshPart& part = model.parts[partIndex];
        auto object = std::make_unique<Object>();
        if (sparsePointsPerObject_ > 0) {
            gi::SparsePointSettings settings;
            const double share = totalArea > 0.0 ? gi::surfaceArea(part.mesh) / totalArea : 1.0;
            settings.pointCount = std::clamp(int(std::lround(share * double(sparsePointsPerObject_))), 16, 65536);
            // A refined mesh's new vertices would need weights of their own: a skinned part keeps its vertices.
            settings.refine = skin == nullptr;
            object->sparse = gi::prepareSparsePoints(
                part.mesh, settings, so.name + " part " + std::to_string(partIndex) + " (" + so.mesh.string() + ")");
        }
        object->ownMaterial = part.material;
        if (so.material.diffuseTexture) object->ownMaterial.diffuseTexture = so.material.diffuseTexture->string();
        object->material = object->ownMaterial;
        applyOverride(so.material, object->material);
        if (!object->material.diffuseTexture.empty()) {
            if (part.mesh.texcoords.empty()) {
                log::warning(so.mesh.string() + ": texture " + object->material.diffuseTexture +
                             " ignored: no texture coordinates");
                object->material.diffuseTexture.clear();
            } else {
                object->texture = loadTexture(object->material.diffuseTexture);
            }
        }
        object->world_T_model = so.world_T_model;
        object->visible = so.visible;
        object->mesh = std::move(part.mesh);
        if (!object->mesh.positions.empty()) {
            object->modelMin = object->modelMax = object->mesh.positions.front();
            for (const glm::vec3& position : object->mesh.positions) {
                object->modelMin = glm::min(object->modelMin, position);
                object->modelMax = glm::max(object->modelMax, position);
            }
        }
        if (skin)
            object->skin = Object::Skin{
                .clip = skin, .part = partIndex, .loop = so.skinAnimation->loop, .rest = object->mesh, .scratch = {}};
        object->gpu = GpuMesh::create(object->mesh, so.mesh.string(), skin != nullptr);
        parts.push_back(std::move(object));
    }
    return parts;
}

void Renderer::setScene(const Scene& scene, bool prepareSparsePoints) {
    objects_.clear();
    objectParts_.clear();
    instances_.clear();
    warnedOpen_.clear();
    sparsePointsPerObject_ = prepareSparsePoints ? scene.gi.sparsePoints : 0;
    const std::string sceneName = scene.file.empty() ? std::string("scene") : scene.file.string();
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        std::vector<std::unique_ptr<Object>> parts =
            loadParts(scene.objects[i], sceneName, "/objects/" + std::to_string(i) + "/mesh");
        objectParts_.emplace_back(objects_.size(), parts.size());
        for (auto& part : parts) objects_.push_back(std::move(part));
    }
    rebuildInstances();
    if (scene.lights.size() > std::size_t(kMaxLights))
        throw Error(sceneName, std::nullopt, "/lights: more than 4 lights");
    lights_ = scene.lights;
    renderShadowMaps();
    gl::DebugOutput::throwIfErrors("scene upload");
}

void Renderer::rebuildInstances() {
    instances_.clear();
    for (std::size_t i = 0; i < objects_.size(); ++i) {
        const Object& o = *objects_[i];
        if (o.visible) instances_.push_back({std::uint32_t(i), &o.mesh, o.gpu.view(), o.world_T_model, o.material});
    }
}

std::size_t Renderer::sceneObjectOf(std::uint32_t meshId) const noexcept {
    std::size_t object = 0;
    while (object + 1 < objectParts_.size() && objectParts_[object + 1].first <= meshId) ++object;
    return object;
}

bool Renderer::setObjectPlacement(std::size_t object, const glm::mat4& world_T_model) {
    LIGHTSKIN_ASSERT(object < objectParts_.size(), "scene object index out of range");
    const auto [first, count] = objectParts_[object];
    if (count == 0 || objects_[first]->world_T_model == world_T_model) return false;
    for (std::size_t i = first; i < first + count; ++i) objects_[i]->world_T_model = world_T_model;
    for (gi::MeshInstance& instance : instances_)
        if (instance.meshId >= first && instance.meshId < first + count) instance.world_T_model = world_T_model;
    shadowsStale_ = true;
    return true;
}

bool Renderer::hasDeformingObjects() const noexcept {
    return std::any_of(objects_.begin(), objects_.end(), [](const auto& o) { return o->skin && o->visible; });
}

bool Renderer::deformAt(double timeSeconds) {
    bool deformed = false;
    for (const std::unique_ptr<Object>& object : objects_) {
        if (!object->skin || !object->visible) continue; // a hidden object deforms when it shows again
        Object::Skin& skin = *object->skin;
        boneMatricesInto(*skin.clip, clipTime(skin.clip->clip, skin.loop, timeSeconds), skin.scratch);
        skinPartInto(skin.clip->parts[skin.part], skin.scratch, skin.rest, object->mesh);
        if (object->sparse && !object->sparse->anchors.empty()) {
            gi::followSurfaceInto(object->mesh, object->sparse->anchors, object->sparse->points);
            gi::refitOccluderRadiiInto(object->mesh, object->sparse->vertexNeighbours, object->sparse->points);
        }
        object->modelMin = object->modelMax = object->mesh.positions.front();
        for (const glm::vec3& position : object->mesh.positions) {
            object->modelMin = glm::min(object->modelMin, position);
            object->modelMax = glm::max(object->modelMax, position);
        }
        object->gpu.updateVertices(object->mesh);
        deformed = true;
    }
    shadowsStale_ = shadowsStale_ || deformed;
    return deformed;
}

bool Renderer::setObjectVisible(std::size_t object, bool visible) {
    LIGHTSKIN_ASSERT(object < objectParts_.size(), "scene object index out of range");
    const auto [first, count] = objectParts_[object];
    if (count == 0 || objects_[first]->visible == visible) return false;
    for (std::size_t i = first; i < first + count; ++i) objects_[i]->visible = visible;
    rebuildInstances();
    shadowsStale_ = true;
    return true;
}

void Renderer::setObjectMaterial(std::size_t object, const MaterialOverride& material) {
    LIGHTSKIN_ASSERT(object < objectParts_.size(), "scene object index out of range");
    const auto [first, count] = objectParts_[object];
    for (std::size_t i = first; i < first + count; ++i) {
        Object& o = *objects_[i];
        const std::string texture = o.material.diffuseTexture; // kept: only the albedos and exponent change
        o.material = o.ownMaterial;
        applyOverride(material, o.material);
        o.material.diffuseTexture = texture;
    }
    for (gi::MeshInstance& instance : instances_) instance.material = objects_[instance.meshId]->material;
}

bool Renderer::setLights(std::span<const SceneLight> lights) {
    LIGHTSKIN_ASSERT(lights.size() == lights_.size(), "setLights() changes the scene's lights, not their count");
    bool changed = false;
    for (std::size_t i = 0; i < lights.size(); ++i) {
        SceneLight& l = lights_[i];
        changed = changed || l.position != lights[i].position || l.direction != lights[i].direction ||
                  l.power != lights[i].power;
        l.position = lights[i].position;
        l.direction = lights[i].direction;
        l.power = lights[i].power;
    }
    shadowsStale_ = shadowsStale_ || changed;
    return changed;
}

void Renderer::addObject(const SceneObject& object, const std::string& source) {
    std::vector<std::unique_ptr<Object>> parts = loadParts(object, source, "mesh");
    objects_.reserve(objects_.size() + parts.size());
    objectParts_.emplace_back(objects_.size(), parts.size());
    for (auto& part : parts) objects_.push_back(std::move(part));
    rebuildInstances();
    shadowsStale_ = true;
    gl::DebugOutput::throwIfErrors("object upload");
}

void Renderer::removeObject(std::size_t object) {
    LIGHTSKIN_ASSERT(object < objectParts_.size(), "scene object index out of range");
    const auto [first, count] = objectParts_[object];
    objects_.erase(objects_.begin() + std::ptrdiff_t(first), objects_.begin() + std::ptrdiff_t(first + count));
    objectParts_.erase(objectParts_.begin() + std::ptrdiff_t(object));
    for (auto& [start, n] : objectParts_)
        if (start > first) start -= count;
    rebuildInstances();
    shadowsStale_ = true;
}

std::size_t Renderer::triangleCount() const noexcept {
    std::size_t n = 0;
    for (const auto& o : objects_) n += o->mesh.triangleCount();
    return n;
}

void Renderer::renderShadowMaps() {
    shadowsStale_ = false;
    const int s = options_.shadowMapSize;
    // Standard cube face orientations (GL spec table 8.19 sampling directions).
    const glm::vec3 targets[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    const glm::vec3 ups[6] = {{0, -1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}, {0, -1, 0}, {0, -1, 0}};
    const glm::mat4 projection = glm::perspective(glm::radians(90.0f), 1.0f, float(options_.nearMetres) * 0.2f, float(options_.farMetres));
    const float far[4] = {1e30f, 0, 0, 0};
    glBindFramebuffer(GL_FRAMEBUFFER, shadowFramebuffer_.id());
    glViewport(0, 0, s, s);
    glEnable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    shadowProgram_.use();
    for (std::size_t light = 0; light < lights_.size(); ++light) {
        const glm::vec3 position = lights_[light].position;
        glProgramUniform3fv(shadowProgram_.id(), shadowProgram_.uniformLocation("lightPosition"), 1, glm::value_ptr(position));
        for (int face = 0; face < 6; ++face) {
            glNamedFramebufferTextureLayer(shadowFramebuffer_.id(), GL_COLOR_ATTACHMENT0, shadowCubes_.id(), 0, GLint(light) * 6 + face);
            glClearNamedFramebufferfv(shadowFramebuffer_.id(), GL_COLOR, 0, far);
            glClearNamedFramebufferfi(shadowFramebuffer_.id(), GL_DEPTH_STENCIL, 0, 1.0f, 0);
            setMat4(shadowProgram_, "clip_T_world", projection * glm::lookAt(position, position + targets[face], ups[face]));
            for (const auto& o : objects_) {
                if (!o->visible) continue;
                setMat4(shadowProgram_, "world_T_model", o->world_T_model);
                o->gpu.draw();
            }
        }
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

void Renderer::renderGBuffer(const Pose& world_T_camera) {
    if (shadowsStale_) renderShadowMaps(); // content moved: before the frame's timer (its own cost)
    timer_.beginFrame();
    timer_.begin("gbuffer");
    const glm::mat4 clip_T_world = clipFromWorldAt(world_T_camera);
    camera_T_world_ = glm::mat4(world_T_camera.inverse().matrix());
    view_.clip_T_world = clip_T_world;
    coveredWindowRect_ = options_.shadeCoveredRectOnly ? coveredWindowRect(clip_T_world)
                                                       : glm::ivec4(0, 0, intrinsics_.width, intrinsics_.height);
    view_.cameraPositionWorld = glm::vec3(world_T_camera.translation());

    const float zero[4] = {0, 0, 0, 0};
    // Only the pixels the last draw could write (gbufferWritten_) differ from the clear values: clear those,
    // then draw scissored to this frame's rectangle, which holds every pixel the objects cover (so the
    // scissor changes no pixel; it makes "written" a fact rather than a claim). On llvmpipe clearing the
    // four targets (40 bytes per pixel) over the whole frame cost more than the draw.
    glEnable(GL_SCISSOR_TEST);
    glScissor(gbufferWritten_.x, gbufferWritten_.y, gbufferWritten_.z, gbufferWritten_.w);
    for (GLint i = 0; i < 4; ++i) glClearNamedFramebufferfv(gbufferFramebuffer_.id(), GL_COLOR, i, zero);
    glClearNamedFramebufferfi(gbufferFramebuffer_.id(), GL_DEPTH_STENCIL, 0, 1.0f, 0);
    glScissor(coveredWindowRect_.x, coveredWindowRect_.y, coveredWindowRect_.z, coveredWindowRect_.w);
    gbufferWritten_ = coveredWindowRect_;
    glClearTexImage(indirect_.id(), 0, GL_RGBA, GL_FLOAT, zero); // techniques may write anywhere: all of it
    glBindFramebuffer(GL_FRAMEBUFFER, gbufferFramebuffer_.id());
    glViewport(0, 0, intrinsics_.width, intrinsics_.height);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDisable(GL_CULL_FACE);
    glDisable(GL_BLEND);
    gbufferProgram_.use();
    setMat4(gbufferProgram_, "clip_T_world", clip_T_world);
    const GLuint p = gbufferProgram_.id();
    for (const auto& o : objects_) {
        if (!o->visible) continue;
        setMat4(gbufferProgram_, "world_T_model", o->world_T_model);
        gi::setFrontFaceFor(o->world_T_model); // gl_FrontFacing: the G-buffer's back-face flag
        const glm::mat3 normalMatrix = glm::inverseTranspose(glm::mat3(o->world_T_model));
        glProgramUniformMatrix3fv(p, gbufferProgram_.uniformLocation("normalMatrix"), 1, GL_FALSE, glm::value_ptr(normalMatrix));
        glProgramUniform3fv(p, gbufferProgram_.uniformLocation("diffuseAlbedo"), 1, glm::value_ptr(o->material.diffuseAlbedo));
        glProgramUniform3fv(p, gbufferProgram_.uniformLocation("specularAlbedo"), 1, glm::value_ptr(o->material.specularAlbedo));
        glProgramUniform1f(p, gbufferProgram_.uniformLocation("specularExponent"), o->material.specularExponent);
        glProgramUniform1i(p, gbufferProgram_.uniformLocation("hasTexture"), o->texture ? 1 : 0);
        glBindTextureUnit(0, o->texture ? o->texture.id() : whiteTexture_.id());
        o->gpu.draw();
    }
    glFrontFace(GL_CCW);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_SCISSOR_TEST);
    timer_.end();
}

glm::mat4 Renderer::clipFromWorldAt(const Pose& world_T_camera) const {
    return glm::mat4(clipFromWorld(intrinsics_, world_T_camera, options_.nearMetres, options_.farMetres));
}

glm::ivec4 Renderer::coveredWindowRect(const glm::mat4& clip_T_world) const {
    const glm::ivec4 all(0, 0, intrinsics_.width, intrinsics_.height);
    double lo[2] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
    double hi[2] = {-lo[0], -lo[1]};
    bool any = false;
    for (const auto& o : objects_) {
        if (!o->visible) continue;
        any = true;
        const glm::mat4 clip_T_model = clip_T_world * o->world_T_model;
        for (int corner = 0; corner < 8; ++corner) {
            const glm::vec3 p((corner & 1) != 0 ? o->modelMax.x : o->modelMin.x,
                              (corner & 2) != 0 ? o->modelMax.y : o->modelMin.y,
                              (corner & 4) != 0 ? o->modelMax.z : o->modelMin.z);
            const glm::vec4 clip = clip_T_model * glm::vec4(p, 1.0f);
            // A corner at or behind the near plane: the clipped box can reach any pixel.
            if (!(double(clip.w) >= options_.nearMetres)) return all;
            for (int axis = 0; axis < 2; ++axis) {
                const double window = (double(clip[axis]) / double(clip.w) + 1.0) * 0.5 *
                                      double(axis == 0 ? intrinsics_.width : intrinsics_.height);
                lo[axis] = std::min(lo[axis], window);
                hi[axis] = std::max(hi[axis], window);
            }
        }
    }
    if (!any) return glm::ivec4(0);
    // The triangles lie in the boxes, so their pixels (centres inside a projected triangle) lie in the
    // projected corners' bounding rectangle; one pixel of margin covers float rounding of the projection.
    const auto clampTo = [](double v, int size) { return int(std::clamp(v, 0.0, double(size))); };
    const int x0 = clampTo(std::floor(lo[0]) - 1.0, intrinsics_.width),
              x1 = clampTo(std::ceil(hi[0]) + 1.0, intrinsics_.width);
    const int y0 = clampTo(std::floor(lo[1]) - 1.0, intrinsics_.height),
              y1 = clampTo(std::ceil(hi[1]) + 1.0, intrinsics_.height);
    return glm::ivec4(x0, y0, std::max(0, x1 - x0), std::max(0, y1 - y0));
}

void Renderer::shade(const ShadeOptions& options) {
    timer_.begin("shade");
    const GLuint p = shadeProgram_.id();
    const auto loc = [&](const char* name) { return shadeProgram_.uniformLocation(name); };
    glm::vec3 positions[kMaxLights]{}, directions[kMaxLights]{}, intensities[kMaxLights]{};
    float cosOuter[kMaxLights]{}, cosInner[kMaxLights]{};
    int shadows[kMaxLights]{};
    for (std::size_t i = 0; i < lights_.size(); ++i) {
        const SceneLight& l = lights_[i];
        positions[i] = l.position;
        directions[i] = l.direction;
        intensities[i] = l.power / float(4.0 * std::numbers::pi);
        if (l.type == LightType::Spot) {
            cosInner[i] = std::cos(glm::radians(l.coneAngleDegrees));
            cosOuter[i] = std::cos(glm::radians(std::min(89.9f, l.coneAngleDegrees + std::max(l.coneFalloffDegrees, 0.01f))));
        } else {
            cosOuter[i] = -2.0f;
            cosInner[i] = -1.0f;
        }
        shadows[i] = l.castsShadows ? 1 : 0;
    }
    glProgramUniform1i(p, loc("lightCount"), GLint(lights_.size()));
    glProgramUniform3fv(p, loc("lightPosition"), kMaxLights, glm::value_ptr(positions[0]));
    glProgramUniform3fv(p, loc("lightDirection"), kMaxLights, glm::value_ptr(directions[0]));
    glProgramUniform3fv(p, loc("lightIntensity"), kMaxLights, glm::value_ptr(intensities[0]));
    glProgramUniform1fv(p, loc("lightCosOuter"), kMaxLights, cosOuter);
    glProgramUniform1fv(p, loc("lightCosInner"), kMaxLights, cosInner);
    glProgramUniform1iv(p, loc("lightShadows"), kMaxLights, shadows);
    glProgramUniform3fv(p, loc("cameraPosition"), 1, glm::value_ptr(view_.cameraPositionWorld));
    setMat4(shadeProgram_, "camera_T_world", camera_T_world_);
    glProgramUniform1i(p, loc("includeIndirect"), options.includeIndirect ? 1 : 0);
    glProgramUniform1f(p, loc("exposureScale"), std::exp2(options.exposureStops));
    glProgramUniform1i(p, loc("debugView"), int(options.view));

    const GLuint textures[] = {worldPosition_.id(), worldNormal_.id(), diffuseAlbedo_.id(), specular_.id(), indirect_.id(), shadowCubes_.id()};
    glBindTextures(0, 6, textures);
    const GLenum outputTargets[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1,
                                    GLenum(options.linearOutput ? GL_COLOR_ATTACHMENT2 : GL_NONE)};
    glNamedFramebufferDrawBuffers(outputFramebuffer_.id(), 3, outputTargets);
    glBindFramebuffer(GL_FRAMEBUFFER, outputFramebuffer_.id());
    glViewport(0, 0, intrinsics_.width, intrinsics_.height);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_BLEND);
    // Pixels no virtual content covers get shade.frag's output for them (all zero) from a clear, and the
    // shader runs only in the rectangle the objects can cover (renderGBuffer): on llvmpipe every pixel of
    // a full-screen pass costs, and the objects cover a small part of a camera frame. Same images.
    // As in renderGBuffer(): only what the last shade() wrote needs the clear (the linear target is
    // written, and cleared, only with linearOutput: its draw buffer is GL_NONE otherwise).
    const float zero[4] = {0, 0, 0, 0};
    glEnable(GL_SCISSOR_TEST);
    glScissor(outputWritten_.x, outputWritten_.y, outputWritten_.z, outputWritten_.w);
    for (GLint i = 0; i < 2; ++i) glClearNamedFramebufferfv(outputFramebuffer_.id(), GL_COLOR, i, zero);
    outputWritten_ = coveredWindowRect_;
    if (options.linearOutput) {
        glScissor(linearWritten_.x, linearWritten_.y, linearWritten_.z, linearWritten_.w);
        glClearNamedFramebufferfv(outputFramebuffer_.id(), GL_COLOR, 2, zero);
        linearWritten_ = coveredWindowRect_;
    }
    glScissor(coveredWindowRect_.x, coveredWindowRect_.y, coveredWindowRect_.z, coveredWindowRect_.w);
    shadeProgram_.use();
    glBindVertexArray(emptyVertexArray_.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glDisable(GL_SCISSOR_TEST);
    glBindVertexArray(0);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    timer_.end();
}

void Renderer::readShadedInto(const gl::Texture& texture, int cvType, unsigned format, unsigned type,
                              cv::Mat& out) const {
    // Outside the shaded rectangle shade() wrote zeros: read only the rectangle (llvmpipe converts every
    // pixel it reads back), zero the rest, and flip the rows to top-first.
    const int w = intrinsics_.width, h = intrinsics_.height;
    out.create(h, w, cvType);
    const glm::ivec4 r = coveredWindowRect_;
    if (r.z <= 0 || r.w <= 0) {
        out.setTo(cv::Scalar::all(0));
        return;
    }
    if (r.z < w || r.w < h) out.setTo(cv::Scalar::all(0));
    readbackScratch_.create(h, w, cvType); // once: a header of the rectangle's size over its memory below
    cv::Mat rect(r.w, r.z, cvType, readbackScratch_.data);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glGetTextureSubImage(texture.id(), 0, r.x, r.y, 0, r.z, r.w, 1, format, type,
                         GLsizei(rect.total() * rect.elemSize()), rect.data);
    cv::flip(rect, out(cv::Rect(r.x, h - r.y - r.w, r.z, r.w)), 0);
}

void Renderer::readOutputsInto(cv::Mat& colourRgba, cv::Mat& depthMetres) const {
    readShadedInto(outputColour_, CV_8UC4, GL_RGBA, GL_UNSIGNED_BYTE, colourRgba);
    readShadedInto(outputDepth_, CV_32FC1, GL_RED, GL_FLOAT, depthMetres);
}

void Renderer::readIndirectInto(cv::Mat& out) const { gl::readTextureRgba32fInto(indirect_, out); }

void Renderer::readLinearOutputInto(cv::Mat& out) const {
    readShadedInto(outputLinear_, CV_32FC4, GL_RGBA, GL_FLOAT, out);
}

void Renderer::lastStageTimes(std::vector<gl::StageTime>& out) { timer_.collect(out); }

} // namespace lightskin::render
