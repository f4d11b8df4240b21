#pragma once
// Renders a scene's virtual content for one camera view: G-buffer (gi::GBufferView, exactly as
// documented there), shadow maps of the virtual lights, direct Phong light, the indirect light a
// gi::IndirectIllumination technique wrote, and tone mapping to sRGB.
//
// Ownership: the Renderer owns the meshes (GpuMesh), G-buffer, shadow maps, the indirect target
// texture and the output textures; all are created once (create()/setScene()) and reused every
// frame. Needs a current OpenGL 4.5 core context; destroy before the context.
//
// Outputs (width x height of the colour camera):
// - colour: RGBA8, rgb = sRGB-encoded tone-mapped radiance, a = 255 where virtual content covers
//   the pixel, 0 elsewhere (rgb = 0 there);
// - depth: R32F, the virtual surface's camera-frame z in metres (along the optical axis, like the
//   sensor's depth), 0 where nothing is covered;
// - linear (written only by shade() with ShadeOptions::linearOutput): RGBA32F,
//   rgb = 2^exposureStops * L before the clamp and the sRGB encoding (values > 1
//   and NaN/inf are kept: what the colour output would show as clamped), a = 1 covered, 0 not
//   (rgb = 0 there). Normals view: pow(display, 2.2); albedo view: the albedo.
// Tone mapping: displayed = sRGB_encode(clamp(2^exposureStops * L, 0, 1)), L linear radiance in
// W/(sr m^2) (the lights' power in watts; the VALs' flux unit for the indirect part).

#include <lightskin/core/CameraIntrinsics.h>
#include <lightskin/core/Pose.h>
#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gi/common/SparsePointSet.h>
#include <lightskin/gl/GpuTimer.h>
#include <lightskin/gl/Objects.h>
#include <lightskin/render/GpuMesh.h>
#include <lightskin/render/Scene.h>

#include <glm/vec4.hpp>
#include <opencv2/core/mat.hpp>

#include <memory>
#include <span>
#include <string>
#include <vector>

namespace lightskin::render {

enum class DebugView {
    Final,        ///< direct + indirect (when enabled), tone mapped
    DirectOnly,
    IndirectOnly,
    Normals,      ///< world normal * 0.5 + 0.5
    Albedo,       ///< diffuse albedo
};
const char* toString(DebugView view) noexcept;

struct ShadeOptions {
    bool includeIndirect = true;
    float exposureStops = 0.0f;
    DebugView view = DebugView::Final;
    /// Also write the linear output (readLinearOutputInto); off, its float target is not written
    /// (llvmpipe: the extra RGBA32F store costs about as much as the rest of shade()).
    bool linearOutput = false;
};

struct RendererOptions {
    double nearMetres = 0.05;
    double farMetres = 20.0;
    int shadowMapSize = 256; ///< per cube face (llvmpipe: keep small)
    /// shade() runs its shader only in the rectangle the objects' bounding boxes project to (shadedWindowRect())
    /// and clears the rest to shade.frag's output for uncovered pixels (0): the same images, fewer pixels.
    /// false: the whole viewport (tests compare the two).
    bool shadeCoveredRectOnly = true;
};

class Renderer {
public:
    /// Creates G-buffer and outputs for `intrinsics.width x height`. Throws lightskin::Error.
    static std::unique_ptr<Renderer> create(const CameraIntrinsics& intrinsics, const RendererOptions& options = {});
    ~Renderer();
    Renderer(const Renderer&) = delete;
    Renderer& operator=(const Renderer&) = delete;

    /// Loads the scene's meshes (throws lightskin::Error naming the scene file, object and mesh),
    /// uploads them, applies material overrides and renders the shadow maps (again only after something moved:
    /// the calls below).
    /// With `prepareSparsePoints` (the LightSkin technique needs them), each mesh part gets its
    /// sparse points (gi::prepareSparsePoints, scene.gi.sparsePoints per object, split over its
    /// parts by surface area, at least 16 each) *before* upload, because that step may refine the
    /// mesh and the renderer must draw the refined mesh (vertexNeighbours index its vertices).
    void setScene(const Scene& scene, bool prepareSparsePoints = false);

    // Moving content: changes to the prepared scene's objects (index = the scene's object index) and lights
    // between frames. Each takes effect from the next renderGBuffer() (which renders the shadow maps again
    // after any change to what casts or where the lights are). No allocation beyond add/remove.
    /// Places every part of scene object `object`; false when the placement was already this one.
    bool setObjectPlacement(std::size_t object, const glm::mat4& world_T_model);
    /// Shows or hides scene object `object` (hidden: not drawn, casts no shadow, not in instances());
    /// false when unchanged. Changes instances(): techniques must be prepared again.
    bool setObjectVisible(std::size_t object, bool visible);
    /// Applies `material`'s albedos and exponent over each part's own material (its texture is not read).
    void setObjectMaterial(std::size_t object, const MaterialOverride& material);
    /// The scene's lights with new position, direction, power (the count and types as setScene()'s);
    /// false when nothing changed.
    bool setLights(std::span<const SceneLight> lights);
    /// Deforms the visible skinned objects (SceneObject::skinAnimation) to their clip at `timeSeconds` (seconds from
    /// the first frame): linear blend skinning of each part's rest mesh into the mesh instances() point to, their
    /// sparse points carried along (gi::followSurfaceInto; radii refitted, neighbours kept), their bounding boxes and
    /// GPU vertices updated (no allocation). Returns false when no visible object is skinned. The techniques' prepared
    /// copies do not follow by themselves: the caller prepares them again (mr::FramePipeline does).
    bool deformAt(double timeSeconds);
    /// True when a visible scene object deforms (deformAt has work).
    bool hasDeformingObjects() const noexcept;

    /// Loads, prepares and uploads `object` as the last scene object (sparse points as setScene() did).
    /// Throws lightskin::Error naming `source` and the mesh; on error nothing changed.
    void addObject(const SceneObject& object, const std::string& source);
    /// Removes scene object `object`; later objects move down by one.
    void removeObject(std::size_t object);
    std::size_t sceneObjectCount() const noexcept { return objectParts_.size(); }
    /// The scene object whose part is instance `meshId`.
    std::size_t sceneObjectOf(std::uint32_t meshId) const noexcept;
    /// The prepared sparse points of instance `meshId`, or nullptr when they were not prepared.
    const gi::SparsePointSet* sparsePoints(std::uint32_t meshId) const noexcept;
    /// The visible objects as the GI techniques see them (valid until the next setScene(), setObjectVisible(),
    /// addObject() or removeObject()).
    std::span<const gi::MeshInstance> instances() const noexcept { return instances_; }

    /// Per frame: fills the G-buffer for the camera at `world_T_camera`.
    void renderGBuffer(const Pose& world_T_camera);
    const gi::GBufferView& gbuffer() const noexcept { return gbufferView_; }
    /// The clip_T_world that renderGBuffer(world_T_camera) puts into viewParameters(), the same bits,
    /// without drawing (for work on a later frame's view, e.g. mr::FramePipeline's GI ahead).
    glm::mat4 clipFromWorldAt(const Pose& world_T_camera) const;
    gi::ViewParameters viewParameters() const noexcept { return view_; }
    /// The RGBA32F texture techniques write indirect radiance into (cleared to 0 by renderGBuffer()).
    std::uint32_t indirectTarget() const noexcept { return indirect_.id(); }
    /// The shadow maps of the scene's lights (R32F cube-map array, layer 6 * light + face: distance in
    /// metres from the light to the nearest virtual surface), rendered by setScene(); owned here.
    std::uint32_t shadowMapTexture() const noexcept { return shadowCubes_.id(); }

    /// Direct light + (optionally) the indirect target, tone mapped, into the output textures.
    void shade(const ShadeOptions& options);
    /// Reads the outputs: colour CV_8UC4 (RGBA, sRGB), depth CV_32FC1 (metres), top row first.
    void readOutputsInto(cv::Mat& colourRgba, cv::Mat& depthMetres) const;

    /// The output textures of the last shade() (see "Outputs" above; GL convention, row 0 = bottom):
    /// for drawing them into a host's framebuffer without a read-back. Owned by the renderer.
    std::uint32_t outputColourTexture() const noexcept { return outputColour_.id(); }
    std::uint32_t outputDepthTexture() const noexcept { return outputDepth_.id(); }

    /// Reads the indirect target (CV_32FC4 linear RGBA, top row first): debug views.
    void readIndirectInto(cv::Mat& out) const;
    /// Reads the linear output of the last shade() with linearOutput (CV_32FC4, see "linear" above,
    /// top row first; stale or undefined after a shade() without it).
    void readLinearOutputInto(cv::Mat& out) const;

    /// The GL window rectangle (x, y from the bottom left, width, height; pixels) that shade() runs its
    /// shader in, set by renderGBuffer(): every pixel the objects can cover; the whole viewport when an
    /// object's bounding box reaches behind the near plane or RendererOptions::shadeCoveredRectOnly is off.
    glm::ivec4 shadedWindowRect() const noexcept { return coveredWindowRect_; }

    /// GPU times of the last renderGBuffer()/shade() pair ("gbuffer", "shade").
    void lastStageTimes(std::vector<gl::StageTime>& out);

    const CameraIntrinsics& intrinsics() const noexcept { return intrinsics_; }
    std::size_t triangleCount() const noexcept;

private:
    Renderer() = default;
    struct Object;
    void renderShadowMaps();
    /// The parts of one scene object, loaded and prepared (nothing of the renderer changes).
    std::vector<std::unique_ptr<Object>> loadParts(const SceneObject& object, const std::string& source,
                                                   const std::string& pointer);
    void rebuildInstances();
    /// GL window rectangle (x, y from the bottom left, width, height) that holds every pixel the objects can
    /// cover under clip_T_world; the whole viewport when a bounding-box corner is not in front of the near plane.
    glm::ivec4 coveredWindowRect(const glm::mat4& clip_T_world) const;
    /// Reads an output of shade() (GL format/type) into `out` (top row first), only its shaded rectangle.
    void readShadedInto(const gl::Texture& texture, int cvType, unsigned format, unsigned type, cv::Mat& out) const;

    CameraIntrinsics intrinsics_;
    RendererOptions options_;
    std::vector<std::unique_ptr<Object>> objects_; ///< mesh parts, scene object by scene object
    /// Per scene object: its first part in objects_ and the part count.
    std::vector<std::pair<std::size_t, std::size_t>> objectParts_;
    int sparsePointsPerObject_ = 0;                 ///< setScene()'s (0 = no sparse points)
    bool shadowsStale_ = false;                     ///< renderShadowMaps() before the next frame
    std::vector<std::filesystem::path> warnedOpen_; ///< model files whose open boundary was reported
    std::vector<gi::MeshInstance> instances_;
    std::vector<SceneLight> lights_;

    gl::Program gbufferProgram_, shadowProgram_, shadeProgram_;
    gl::Texture worldPosition_, worldNormal_, diffuseAlbedo_, specular_, depth_, indirect_;
    gl::Framebuffer gbufferFramebuffer_;
    gl::Texture shadowCubes_; ///< R32F cube map array, 6 layers per light: distance to the light, metres
    gl::Renderbuffer shadowDepth_;
    gl::Framebuffer shadowFramebuffer_;
    gl::Texture outputColour_, outputDepth_, outputLinear_;
    gl::Framebuffer outputFramebuffer_;
    gl::VertexArray emptyVertexArray_;
    gl::Texture whiteTexture_;
    gl::GpuStageTimer timer_;
    gi::GBufferView gbufferView_;
    gi::ViewParameters view_;
    glm::mat4 camera_T_world_{1.0f};
    glm::ivec4 coveredWindowRect_{0}; ///< of the last renderGBuffer(): shade() runs its shader only there
    /// Window rectangles outside which the G-buffer / the colour and depth outputs / the linear output hold
    /// their clear values (what the last draw into them could write): the next clear covers only these.
    glm::ivec4 gbufferWritten_{0}, outputWritten_{0}, linearWritten_{0};
    mutable cv::Mat readbackScratch_; ///< readShadedInto()'s rectangle, sized once
};

} // namespace lightskin::render
