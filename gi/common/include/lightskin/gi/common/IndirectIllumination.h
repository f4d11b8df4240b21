#pragma once
// The interface every indirect-illumination technique implements (the list: lightskin/gi/Techniques.h).
// The renderer owns meshes, G-buffer and target; a technique owns only its own GPU resources (created in
// prepare(), reused every frame). What a technique can do beyond render() it says in capabilities(), so
// that a pipeline needs to know no concrete technique.
//
// GL objects are passed as GL names (std::uint32_t) so that engines owning the context can hand
// in their own. All need a current OpenGL 4.5 core context on the calling thread.

#include <lightskin/core/Material.h>
#include <lightskin/core/TriangleMesh.h>
#include <lightskin/gi/common/Technique.h>
#include <lightskin/gi/common/VirtualAreaLight.h>
#include <lightskin/gl/GpuTimer.h>

#include <glm/mat4x4.hpp>
#include <glm/vec4.hpp>

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

namespace lightskin::gi {

/// A mesh on the GPU, owned by the renderer. The vertex array has attribute 0 = position (vec3,
/// model space), 1 = normal (vec3, model space), 2 = texcoord (vec2, optional) and an element
/// buffer of GL_UNSIGNED_INT triangle indices bound. Vertex order equals the TriangleMesh's.
struct GpuMeshView {
    std::uint32_t vertexArray = 0;
    std::uint32_t indexCount = 0;
    std::uint32_t vertexCount = 0;
};

/// One placed virtual object.
struct MeshInstance {
    std::uint32_t meshId = 0;           ///< stable id of the mesh across frames (prepared data key)
    const TriangleMesh* mesh = nullptr; ///< CPU copy, model space; must outlive the technique's use
    GpuMeshView gpu;
    glm::mat4 world_T_model{1.0f}; ///< rigid (+ uniform scale) placement in the world, metres
    Material material;
};

/// Sets glFrontFace for drawing a mesh placed by `world_T_model`: front = the mesh's counter-clockwise
/// winding, which is clockwise on screen under a mirroring placement (negative determinant), whatever the
/// host's GL state. Every pass that reads gl_FrontFacing (the G-buffer's back-face flag, the shade passes)
/// sets it per placement and restores GL_CCW after.
void setFrontFaceFor(const glm::mat4& world_T_model);

/// The renderer's G-buffer of the virtual content, all textures width x height.
struct GBufferView {
    std::uint32_t worldPosition =
        0; ///< RGBA32F: xyz world metres; w = 1 where virtual content covers the pixel, else 0
    /// RGBA16F or RGBA32F: xyz unit world normal, turned toward the viewer on back faces (two-sided
    /// surfaces, for the direct light); w = 1 where the pixel shows a back face, 0 on a front face.
    /// A back face of a mesh with outward normals is the object's inside, seen through a hole in the
    /// mesh (a scan's holes, bun_zipper_res4.ply). Light reaches an object's inside only through its
    /// holes: against the ray-traced truth with visibility, the inside of a 16 cm box seen through a
    /// 4 cm hole gets 11 % of its lit outside's light (0 through that hole alone: it looks back at the
    /// room behind the camera, which no depth pixel sees), lit without visibility 17-42x the truth
    /// (gi_back_face_hole_gl_test). So every technique writes 0 there: LightSkin (GL and CPU), the
    /// brute force, imperfect volumes (in its reconstruction) and multi-scale PRT (in its per-pixel
    /// shade pass; its per-vertex exit irradiance is the outside's light). A sheet seen from behind
    /// (an open surface meant to be two-sided) gets no indirect light either (LightSkin's sparse
    /// points see the light of the front side only). The differential irradiance of the real surfaces
    /// does not read this G-buffer (its receivers come from the depth image).
    std::uint32_t worldNormal = 0;
    std::uint32_t diffuseAlbedo = 0; ///< RGBA8 or RGBA16F: rgb linear rho_d
    std::uint32_t specular = 0;      ///< RGBA16F or RGBA32F: rgb f_s, a = Phong exponent k
    std::uint32_t depth = 0;         ///< DEPTH_COMPONENT32F of the virtual content (for depth-equal passes)
    int width = 0;
    int height = 0;
};

/// The real surface as the depth camera sees it this frame, registered to the colour camera (one depth
/// per colour pixel). LightSkin uses it to leave out sparse points buried under the real surface
/// (guard G11, lightskin_math.glsl); the other techniques ignore it. Not owned: the texture and the
/// CPU map must stay unchanged until render() returns. Either may be absent (0 / null): the GL
/// technique reads `texture`, the CPU backend `data`; absent = no point is buried.
struct RealDepthView {
    /// GL R32F texture, width x height: texel (u, v) is image column u, row v (row 0 = the image's
    /// top row, as uploaded from an OpenCV image); metres along the optical axis; <= 0 or NaN = hole.
    std::uint32_t texture = 0;
    const float* data = nullptr; ///< the same map on the CPU, row-major, `width` floats per row
    int width = 0;
    int height = 0;
    glm::vec4 intrinsics{0.0f};     ///< fx, fy, cx, cy in pixels (fy may be negative); pixel centres at integers
    glm::mat4 camera_T_world{1.0f}; ///< rigid; camera frame x right, y down, z forward (OpenCV)
};

struct ViewParameters {
    ViewParameters() = default;
    // A constructor (not an aggregate) so that the many {clip, eye} call sites need no realDepth.
    ViewParameters(const glm::mat4& clip, const glm::vec3& eye, const RealDepthView& depth = {})
        : clip_T_world(clip)
        , cameraPositionWorld(eye)
        , realDepth(depth) {}

    glm::mat4 clip_T_world{1.0f};        ///< projection * view of the (colour) camera
    glm::vec3 cameraPositionWorld{0.0f}; ///< metres
    RealDepthView realDepth;             ///< the real surface for LightSkin's guard G11; none by default
};

/// Where VALs on the CPU come from the pixels of an image (gi::CpuValGenerator::lastPixelIndices()):
/// keys[i] = v * width + u names VAL i's pixel, one key per VAL, no pixel twice. With
/// valTreeThreshold > 0 the gather then cuts through the image's quadtree (O(pixels) to build)
/// instead of the BVH (O(n log n)); ValTree.h. Not kept after the call.
struct CpuValPixelKeys {
    std::span<const std::uint32_t> keys; ///< empty: the VALs are not an image's (BVH)
    std::uint32_t width = 0, height = 0; ///< the image, pixels
};

/// A technique that takes its VALs on the CPU (no read-back of a GL buffer) and can split a frame into
/// the CPU stages (computeVpls, no GL call, any thread) and the GL shading (shadeVpls).
class CpuValTechnique {
public:
    /// Worker threads of the CPU stages (0 = all hardware threads); the CPU VAL generator uses as many.
    virtual int threads() const noexcept = 0;
    /// render() with the VALs already on the CPU; `pixels`: the VALs' image pixels, if any.
    virtual void renderCpuVals(std::span<const VirtualAreaLight> lights, std::span<const MeshInstance> instances,
                               const GBufferView& gbuffer, const ViewParameters& view, std::uint32_t targetTexture,
                               const CpuValPixelKeys& pixels) = 0;
    /// The CPU stages alone (no GL call; may run on another thread for a later frame once shadeVpls() returned).
    virtual void computeVpls(std::span<const VirtualAreaLight> lights, std::span<const MeshInstance> instances,
                             const glm::vec3& cameraPositionWorld, const CpuValPixelKeys& pixels,
                             const RealDepthView& realDepth) = 0;
    /// The GL half: uploads the last computeVpls()'s result and shades into `targetTexture`.
    virtual void shadeVpls(std::span<const MeshInstance> instances, const GBufferView& gbuffer,
                           const ViewParameters& view, std::uint32_t targetTexture) = 0;

protected:
    ~CpuValTechnique() = default;
};

/// A stage of lastStageTimes() measured on the CPU (wall clock) and the label a frame report gives it.
struct CpuStageLabel {
    const char* stage;
    const char* label;
};

/// What a technique can do, for pipelines and the frame budget.
struct TechniqueCapabilities {
    bool glossy = false;       ///< renders the glossy channel (the budget's "glossy" knob)
    bool occlusion = false;    ///< has an occlusion stage (the budget's "occlusion" knob)
    bool sparsePoints = false; ///< needs the renderer's sparse points of every mesh (the "sparse points" knob)
    bool vertexVpls = false;   ///< readVertexVpls() and vertexOffsets() (the per-vertex VPL debug view)
    /// prepare() bakes the instances' world placement (a world-space precompute): after an instance moved,
    /// render() needs prepare() again. false: render() takes any world_T_model (model-space preparation).
    bool placementInPrepare = false;
    /// Lights the objects with the scene lights given at creation (TechniqueConfig): after a light changed,
    /// the technique must be created again.
    bool sceneLightsAtCreation = false;
    /// The stages of lastStageTimes() that are CPU wall times, with their frame-report labels; every
    /// other stage is a GPU time. Empty: all are GPU times.
    std::span<const CpuStageLabel> cpuStages;
};

/// What the last render() did beyond its image (-1: the technique does not say).
struct TechniqueFrameStatistics {
    int reused = -1;                 ///< adaptive LightSkin: 1 = the last light reused (static content), 0 = computed
    float changeMeasure = -1.0f;     ///< its bound on the change since the reused frame
    std::int64_t voxelsDropped = -1; ///< imperfect volumes: voxels dropped for lack of capacity
};

class IndirectIllumination {
public:
    virtual ~IndirectIllumination() = default;
    IndirectIllumination() = default;
    IndirectIllumination(const IndirectIllumination&) = delete;
    IndirectIllumination& operator=(const IndirectIllumination&) = delete;

    /// A display name for reports ("lightskin", "lightskin-cpu", ...); choices use technique() and backend().
    virtual std::string_view name() const = 0;
    virtual Technique technique() const noexcept = 0;
    virtual Backend backend() const noexcept { return Backend::Gl; }
    virtual TechniqueCapabilities capabilities() const noexcept { return {}; }

    /// Model-space preparation when the set of meshes changes (not per frame): sparse points,
    /// neighbour tables, GPU buffers sized for these meshes. Throws lightskin::Error on bad meshes.
    virtual void prepare(std::span<const MeshInstance> instances) = 0;

    /// Per frame: writes the indirect radiance reflected toward the camera (linear RGB, W/(sr m^2)
    /// up to the VALs' flux unit) into `targetTexture` (RGBA32F, gbuffer size) for every pixel the
    /// virtual content covers; other pixels are set to 0. An empty VAL set gives exactly 0.
    virtual void render(const ValSetView& lights, std::span<const MeshInstance> instances, const GBufferView& gbuffer,
                        const ViewParameters& view, std::uint32_t targetTexture) = 0;

    /// Stage times of the last render(), in execution order (GL timer queries; capabilities().cpuStages
    /// names those measured on the CPU).
    virtual void lastStageTimes(std::vector<gl::StageTime>& out) const = 0;
    virtual TechniqueFrameStatistics lastFrameStatistics() const { return {}; }

    /// Not null when the technique takes VALs on the CPU (CpuValTechnique).
    virtual CpuValTechnique* cpuValInput() noexcept { return nullptr; }

    /// capabilities().vertexVpls: the per-vertex VPLs of the last render(), 4 vec4 per vertex ((L_d, rbar^2),
    /// (l_d world, 0), glossy ...), and each prepared instance's first vertex in them. Otherwise empty.
    virtual void readVertexVpls(std::vector<glm::vec4>& out) const { out.clear(); }
    virtual const std::vector<std::uint32_t>& vertexOffsets() const noexcept;
};

} // namespace lightskin::gi
