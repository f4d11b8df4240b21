#pragma once
// The per-frame pipeline shared by `lightskin replay` and `lightskin live`:
//   depth (metres, filtered) -> pose (ground truth | AprilTag tracking | fixed) -> [the room's light estimated
//   (a scene light of type estimated: roomlight::RoomLightEstimator, EstimatedLight.h)] -> VALs from depth
//   [+ VALs from reflective shadow maps of the virtual meshes per scene light (gi.virtualBounce),
//   merged after the depth VALs] -> G-buffer -> GI technique (gi::IndirectIllumination) -> direct + indirect, tone
//   mapped
//   -> composite over the colour image (with GI, and without GI for the figure-4 comparison).
// Everything is sized on the first frame and reused; needs a current GL 4.5 context.

#include <lightskin/capture/FrameSource.h>
#include <lightskin/core/RgbdFrame.h>
#include <lightskin/gi/common/CpuValGenerator.h>
#include <lightskin/gi/common/IndirectIllumination.h>
#include <lightskin/gi/common/ReflectiveShadowMap.h>
#include <lightskin/gi/common/Technique.h>
#include <lightskin/gi/prt/MultiscalePrt.h>
#include <lightskin/gl/GpuTimer.h>
#include <lightskin/mr/EstimatedLight.h>
#include <lightskin/render/Compositor.h>
#include <lightskin/render/Renderer.h>
#include <lightskin/render/Scene.h>
#include <lightskin/roomlight/LightEstimate.h>
#include <lightskin/tracking/PoseTracker.h>

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace lightskin::mr {

enum class PoseMode { GroundTruth, Tracking, Fixed };
const char* toString(PoseMode mode) noexcept;
/// "ground-truth", "tracking", "fixed"; throws lightskin::Error otherwise.
PoseMode parsePoseMode(const std::string& text);

/// The scene's lights as RSM lights: intensity I = power / (4 pi) W/sr (as the renderer's direct
/// light, for points and spots alike); a spot's uniform RSM cone has the half angle
/// coneAngleDegrees + coneFalloffDegrees / 2 (the middle of the renderer's smooth falloff, which
/// keeps the spot's power to first order in the falloff width), clamped to 1.5 rad (86 degrees).
std::vector<gi::VirtualLight> virtualLightsFromScene(const render::Scene& scene);

/// Debug overlays drawn over the with-GI composite (beyond the renderer's DebugView):
/// Vals: every VAL as a dot at its position, coloured by its flux (normalised to the frame's
/// brightest VAL); SparsePoints: the technique's sparse points (LightSkin only); ErrorVsBruteForce:
/// |indirect(technique) - indirect(brute force)| per pixel as a colour map (blue 0 .. red at
/// errorScale, linear RGB luminance), with the mean relative error in the corner (brute force has no
/// occlusion term, so with occlusion on the difference includes it). VertexVpls (LightSkin only):
/// the interpolated diffuse VPL of every n-th vertex of the virtual meshes (eq. 13: l'''_d and
/// L'''_d, after occlusion), at most kMaxVplSegments: a segment from the vertex a quarter of the
/// way toward its VPL position plus a dot at the VPL position, coloured like the vals view
/// (square root of L'''_d normalised to the brightest vertex VPL); segments are clipped at the
/// camera's near plane (5 cm) and drawn without a depth test (hidden vertices too). This view reads the per-vertex VPL
/// buffer back every frame. Differential: the differential composite's change of the real light, dE / E_without
/// (luminance), over the camera image at 35 %: blue where the virtual objects darken the real surface (full blue = -100
/// %), red where they brighten it (full red = +50 %); real pixels outside the affected region stay dimmed grey (the
/// view draws only when the differential runs).
enum class Overlay { None, Vals, SparsePoints, ErrorVsBruteForce, VertexVpls, Differential, LightEstimate };
inline constexpr int kOverlayCount = 7;
inline constexpr std::uint32_t kMaxVplSegments = 2000;

/// Parses a view name: final, direct, indirect, normals, albedo (render::DebugView) or vals,
/// sparse, error, vpl, differential, light (overlays over the final image). Throws lightskin::Error otherwise.
void parseView(const std::string& text, render::DebugView& view, Overlay& overlay);

struct PipelineOptions {
    PoseMode poseMode = PoseMode::GroundTruth;
    bool compare = true; ///< also render without GI (the side-by-side comparison)
    render::DebugView view = render::DebugView::Final;
    Overlay overlay = Overlay::None;
    float errorScale = 0.05f; ///< radiance difference shown as full red in the error view
    bool giEnabled = true;    ///< live toggle; off = direct light only
    /// LightSkin's adaptive mode (LightSkinSettings::adaptive) incl. static-content reuse, and its
    /// tolerance (0 = exact reuse only; > 0 with staticProbes: the probe test, else the bound).
    bool adaptive = false;
    float staticTolerance = 0.0f;
    bool staticProbes = true;
    /// Fill FrameOutput::linearWithGi and its NaN/inf counts (replay: always; live: off, it costs a
    /// float readback and a CPU pass per frame).
    bool linearComposite = false;
    /// Also fill FrameOutput::linearIndirect (replay --linear-out).
    bool linearIndirect = false;
    /// Differential rendering (live toggle): the virtual objects' shadows and reflected light on
    /// the real surfaces (gi::DifferentialIrradiance, render::applyDifferentialInto) in withGi and
    /// linearWithGi (withoutGi stays the plain camera image: the figure-4 comparison). Runs only
    /// when the scene's compositing.differential is on too and depth is registered to colour; it
    /// needs the depth VALs, which it then generates even with GI off.
    bool differential = true;
    /// Also fill FrameOutput::withGiWithoutDifferential (replay: comparing with the objects-present truth).
    bool differentialBaseline = false;
    /// Also fill FrameOutput::linearIndirectReference (the brute force on the same VALs and
    /// G-buffer) and FrameOutput::coverage (`lightskin bench-realdepth`: speckle and flicker of
    /// both side by side). Costs a second GI pass and two float read-backs per frame.
    bool referenceIndirect = false;
    /// The backend override (`lightskin replay --backend`, a host's choice): replaces the gi.backend of the scene
    /// and of every setGiSettings() for the pipeline's life (gi::chooseBackend, reason CommandLine); unset = theirs.
    std::optional<gi::BackendSetting> backend;
    /// A saved room model to start from (roommodel/RoomModelFile.h; `--room-model`): loaded at create(), which throws
    /// lightskin::Error naming the file when it cannot be used (no roomModel in the scene, poses not from tracking,
    /// unregistered depth, a corrupt file or another grid). Empty: the room memory starts empty.
    std::filesystem::path roomModelFile;
};

/// Why a frame had no GI (FrameOutput::giInactiveCause); stable strings for reports and tests.
inline constexpr const char* kGiCauseNoPose = "no camera pose (tracking lost): the camera image passes through";
inline constexpr const char* kGiCauseSwitchedOff = "GI switched off";
inline constexpr const char* kGiCauseNoObjects = "the scene has no virtual objects: the real room is shown alone";
inline constexpr const char* kGiCauseNoTechnique =
    "the GI technique is \"none\" (scene gi.technique, or not in this build)";
inline constexpr const char* kGiCauseUnregistered = "depth is not registered to colour: no VALs";
inline constexpr const char* kGiCauseNoDepth = "the frame has no depth: no VALs";
inline constexpr const char* kGiCauseNoVals = "no depth pixel became a VAL (all missing or out of range)";

struct FrameOutput {
    std::int64_t frameIndex = 0;
    cv::Mat withGi;    ///< CV_8UC3 BGR composite (GI on, or direct only when GI is off)
    cv::Mat withoutGi; ///< CV_8UC3 BGR composite without GI (when compare)
    /// options.differentialBaseline: withGi composited over the plain camera image (no differential;
    /// equal to withGi when the differential did not run), no overlays.
    cv::Mat withGiWithoutDifferential;
    /// options.linearComposite: CV_32FC3 BGR linear-light composite of withGi (render::Compositor::compositeLinearInto:
    /// the view's 2^exposure * radiance before clamp and sRGB encoding, NaN/inf and values > 1 kept;
    /// camera pixels sRGB-decoded). Overlays (vals, sparse, error, vpl) are not drawn into it.
    cv::Mat linearWithGi;
    /// Pixels of linearWithGi with a NaN / an infinite channel (NaN counted first); 0 without linearComposite.
    std::int64_t linearNanPixels = 0, linearInfPixels = 0;
    /// options.linearIndirect and GI ran: CV_32FC3 BGR 2^exposure * the technique's indirect radiance
    /// (unclamped, 0 where no virtual content), else empty.
    cv::Mat linearIndirect;
    /// options.referenceIndirect and GI ran: like linearIndirect, for the brute force on the same VALs.
    cv::Mat linearIndirectReference;
    /// options.referenceIndirect: CV_8UC1, 255 where virtual content covers the pixel (its G-buffer
    /// coverage, independent of the light it receives), else 0.
    cv::Mat coverage;
    /// options.referenceIndirect: CV_8UC1, 255 where the composite shows the covered pixel (any share a > 0
    /// of it: render::Compositor::visibleInto with the frame's filtered depth, the composite's own rule),
    /// 0 where it is uncovered or hidden behind the real depth. What the speckle measures count.
    cv::Mat visibleCoverage;
    /// options.referenceIndirect: CV_32FC1 camera-space depth (metres) of the virtual content.
    cv::Mat virtualDepthMetres;
    /// options.referenceIndirect: CV_32FC3 unit world normals (x, y, z) of the G-buffer, image rows
    /// (turned toward the camera on back faces).
    cv::Mat virtualNormals;
    /// options.referenceIndirect: CV_8UC1, 255 where the G-buffer shows a back face (the inside of an
    /// object seen through a hole in its mesh, where both GI techniques write 0:
    /// gi::GBufferView::worldNormal), else 0; eval::measureSpeckle leaves those pixels out.
    cv::Mat backFacing;
    tracking::TrackingResult tracking;
    std::optional<Pose> world_T_camera;
    /// Whether GI lit this frame: a technique ran on at least one VAL. When false, giInactiveCause
    /// says why (a static string: kGiCause* above), else it is nullptr.
    bool giActive = false;
    const char* giInactiveCause = nullptr;
    std::uint32_t valCount = 0;     ///< VALs from depth
    std::int64_t coveredPixels = 0; ///< pixels the virtual content covers (before occlusion by real depth)
    std::int64_t rsmValCount = -1;  ///< gi.virtualBounce: VALs from the virtual lights' RSMs, else -1
    std::int64_t valsDropped =
        -1; ///< gi.virtualBounce: VALs beyond the merged set's capacity (logged; 0 normally), else -1
    double meanRelativeErrorVsBruteForce = -1.0; ///< error view only: mean |a-b| / mean |b| over covered pixels
    std::int64_t vplSegments = -1;               ///< vpl view only: vertex VPLs drawn (in front of the camera), else -1
    std::int64_t vplNonFinite = -1; ///< vpl view only: vertices (of all) whose l'''_d or L'''_d is not finite, else -1
    /// Wall clock per stage, ms (incl. waiting for the GPU); "content" (frames whose content can move: animation
    /// or a host change) is the placing of moving content before the frame (shadow maps re-render in "gbuffer+gi").
    std::vector<gl::StageTime> cpuTimes;
    std::vector<gl::StageTime> gpuTimes; ///< GL timer queries, ms
    /// Wall clock of process(), its front (filter, pose) included; of render() alone when the front ran
    /// ahead on another thread (Session's prefetch), where it overlaps the previous frame.
    double totalMs = 0.0;
    /// The CPU backend's VALs and GI stages 0-4 of this frame ran while the previous frame rendered (the GI
    /// ahead, FramePipeline::render with a NextFrame); cpuTimes "vals" and "gi ..." are the times they took then.
    bool giComputedAhead = false;
    int giReused = -1;             ///< adaptive LightSkin: 1 = VPLs reused (static content), 0 = recomputed, else -1
    float giChangeMeasure = -1.0f; ///< adaptive LightSkin: LightSkinChoice::staticChangeBound
    /// imperfect volumes: occupied + ray-marched voxels dropped for want of slots (256^3), else -1
    std::int64_t volumeVoxelsDropped = -1;
    std::int64_t differentialReceivers = -1; ///< differential ran: receivers gathered (in the affected region), else -1
    std::int64_t differentialPixels = -1;    ///< differential ran: camera pixels in the affected region, else -1
    /// The scene has a light of type estimated and the frame a pose and registered depth: the room's light as
    /// estimated up to this frame (fitted on this frame when roomLightFitted, else the last fit's), in the camera's
    /// units and the world frame (roomlight/LightEstimate.h); else unset. Its reference point is the centre of the
    /// visible objects' bounding boxes.
    std::optional<roomlight::LightEstimate> lightEstimate;
    bool roomLightFitted = false;
    /// What of lightEstimate became the estimated light's direct light this frame (EstimatedLight.h).
    EstimatedDirectLight estimatedLight;
    /// Thread CPU time of this frame's estimate, ms (0 on frames between fits); -1 without lightEstimate.
    double roomLightCpuMs = -1.0;
};

/// The CPU-only front of a frame (FramePipeline::prepare): the filtered depth and the pose. It uses no
/// GL, so frame n+1's front can run on another thread while frame n renders (Session's prefetch).
/// Sized on first use and reused (no allocation per frame once the size is known).
struct PreparedFrame {
    cv::Mat depthMetres;    ///< CV_32FC1 bilateral-filtered depth in metres, 0 = missing (valid when haveDepth)
    bool haveDepth = false; ///< the frame has depth registered to colour, of the colour image's size
    tracking::TrackingResult tracking;   ///< the pose of the colour camera (PoseMode), world_T_camera empty = lost
    double filterMs = 0.0, poseMs = 0.0; ///< wall clock of the two stages (FrameOutput::cpuTimes)
    /// Wall clock of the room memory (fusion or depth tracking; not in poseMs); -1 without one (scene roomModel).
    double roomMemoryMs = -1.0;
    /// Set by prepare(), one more per call: names this frame to render()'s GI ahead.
    std::uint64_t sequence = 0;
};

/// Where render() finds the frame after the one it renders (Session's prefetch), for the GI ahead.
class NextFrame {
public:
    virtual ~NextFrame() = default;
    /// Waits until the next frame is prepared and points at it (valid until render() of that frame has
    /// returned); false when there is none (the source's end, or its reading or prepare() failed).
    virtual bool wait(const RgbdFrame*& frame, const PreparedFrame*& prepared) = 0;
};

class FramePipeline {
public:
    /// Copies `scene` (its content then changes by animation and the calls below). `source` gives intrinsics and
    /// registration. Throws lightskin::Error on bad scene content (meshes, tracking config) or intrinsics.
    static std::unique_ptr<FramePipeline> create(const render::Scene& scene, const capture::FrameSourceInfo& source,
                                                 const PipelineOptions& options);
    ~FramePipeline();

    /// One frame: prepare() then render(), on this thread.
    void process(const RgbdFrame& frame, FrameOutput& out);
    /// The CPU-only front of `frame` (depth filter, pose) into `prepared`. Touches only the depth filter
    /// and the tracker, no GL, so it may run on another thread while render() draws an earlier frame;
    /// calls must come in frame order (the tracker's temporal filter), one at a time, and
    /// options().poseMode must not change meanwhile.
    void prepare(const RgbdFrame& frame, PreparedFrame& prepared);
    /// The rest of `frame` (VALs, GI, shading, composite) from its prepare() result; needs the GL
    /// context current. The output equals process()'s bit for bit.
    void render(const RgbdFrame& frame, const PreparedFrame& prepared, FrameOutput& out);
    /// render() that, with setGiAhead(true) and the CPU backend, also starts the next frame's GI once this
    /// frame's GL work is queued: its CPU VALs and their occupancy cull here, then stages 0-4 of the
    /// technique (gi::CpuLightSkin::computeVpls) on a worker thread while this frame's read-backs and
    /// composite run; the next render() of that frame (with its PreparedFrame) then only shades. Used
    /// when the frame's VALs and GI would be the same as computed now (same settings, options and
    /// prepared frame), else the next render() computes them itself: the images equal render()'s bit for
    /// bit. An error of the next frame's VALs or GI is thrown by the render() of that frame.
    void render(const RgbdFrame& frame, const PreparedFrame& prepared, FrameOutput& out, NextFrame* next);
    /// Turns the GI ahead of render(..., next) on or off (off: waits for a running one and drops it).
    /// Session turns it on with its prefetch and without a frame budget (whose cost model times the GI).
    void setGiAhead(bool on);
    /// Waits for a GI ahead that is running and drops its result. Call before the frames handed to
    /// render(..., next) go away (Session does, before its prefetch).
    void finishGiAhead();
    /// Whether the scene's room memory runs (a roomModel block, poses from tracking, registered depth).
    bool hasRoomMemory() const noexcept;
    /// Saves the room memory's model (roommodel::saveRoomModel: replaced atomically, never over another kind of file).
    /// Throws lightskin::Error naming the file when there is no room memory or it cannot be written. Not while
    /// prepare() runs on another thread (Session::saveRoomModel stops its prefetch first).
    void saveRoomModel(const std::filesystem::path& file) const;
    /// Replaces the room memory's model by a saved one (roommodel::RoomMemory::loadModel). Throws lightskin::Error
    /// naming the file when there is no room memory or the file cannot be used (nothing changes then).
    void loadRoomModel(const std::filesystem::path& file);
    /// Differential rendering (the scene's compositing.differential) on a thread of its own, beside the
    /// frame's G-buffer, GI and shading, collected before the composite; off: on the caller's thread, before the
    /// GI. The images are the same either way. Session turns it on with the GI ahead (not under a frame budget,
    /// whose cost model times the stages one after another). Between frames only.
    void setDifferentialAlongside(bool on);

    // Moving content (docs/PLUGIN.md, "Moving content"). Object and light indices are the scene's (objects
    // added later come last; removing one moves the later ones down). Each call checks its input and throws
    // lightskin::Error naming the scene, the object or light and the cause, changing nothing; the GL context
    // must be current for the calls that change the set of drawn objects (visible, add, remove).

    /// The virtual content as it is now: the scene with the host's changes and, after a frame, the placements
    /// and light values its animations had at that frame's time.
    const render::Scene& scene() const noexcept;
    /// Places an object from the next frame on (world_T_model: rotation * uniform scale + translation, metres;
    /// render::composeTransform). Stops its animation: the host drives it from now on.
    void setObjectTransform(std::size_t object, const glm::mat4& world_T_model);
    /// Hidden objects are not drawn, cast no shadow and take no part in GI. The techniques are prepared again
    /// (a one-off cost, docs/BENCHMARKS.md).
    void setObjectVisible(std::size_t object, bool visible);
    /// Sets the albedos and exponent set in `material` (unset ones: the mesh file's); its texture is ignored.
    void setObjectMaterial(std::size_t object, const render::MaterialOverride& material);
    /// A light's position (world, metres), direction (spot lights; unit after normalising, ignored for point
    /// lights) and power (watts, linear RGB, >= 0) from the next frame on. Stops its animation. A light of type
    /// estimated is set by the estimate every frame: an error.
    void setLight(std::size_t light, const glm::vec3& position, const glm::vec3& direction, const glm::vec3& power);
    /// Loads `object` (mesh and texture paths absolute or relative to the working directory; name required)
    /// and adds it as the last object; returns its index. The techniques are prepared again.
    std::size_t addObject(render::SceneObject object);
    void removeObject(std::size_t object);

    PipelineOptions& options() noexcept { return options_; }
    /// Rebuilds the GI technique with changed settings (live toggles of glossy/occlusion; the frame
    /// budget's choices). A changed valStride recreates the VAL generator; changed sparsePoints
    /// (LightSkin) prepare the meshes again (Renderer::setScene): both cost a one-off stall.
    void setGiSettings(const render::GiSettings& settings);
    const render::GiSettings& giSettings() const noexcept { return gi_; }
    /// The technique's display name for reports ("lightskin-cpu" for LightSkin on the CPU).
    std::string techniqueName() const;
    gi::Technique technique() const noexcept;
    gi::Backend backend() const noexcept;
    /// The technique's backend and why, as the last setGiSettings() chose it from its settings' backend (which
    /// giSettings() keep as given, "auto" too), the options' override and the GL renderer, classified once at
    /// creation: "auto" is the CPU backend on a software rasterizer, else gl (gi::chooseBackend).
    const gi::BackendChoice& backendChoice() const noexcept;
    /// Technique multiscale-prt: its last prepare() (precompute or cache load), else nullopt.
    std::optional<gi::PrtPrepareStats> prtPrepareStats() const;
    render::Renderer& renderer() noexcept { return *renderer_; }
    /// Diagnostics (`bench-realdepth --maps`): the last frame's depth VALs as the techniques received
    /// them (after the occupancy cull: culled VALs have area 0) and the depth pixel (v * width + u) of
    /// each; empty without a GL VAL generator (unregistered depth, or the CPU backend's own VALs).
    /// Reads the GPU buffers back: not for per-frame use.
    void downloadDepthValsInto(std::vector<gi::VirtualAreaLight>& vals, std::vector<std::uint32_t>& pixels) const;

private:
    FramePipeline() = default;
    void createValGenerator(int stride);
    /// Moving content: the animations at this frame's time into the renderer, and what depends on placements.
    void applyContentAt(double timeSeconds);
    /// `deformed`: a skinned object's vertices changed too (the techniques' model-space copies are stale).
    void contentMoved(bool deformed);
    /// Throws lightskin::Error naming the object when `technique` cannot follow a deforming object of the scene.
    void refuseDeformationFor(gi::Technique technique) const;
    /// The GI ahead's instances for the frame `sequence`: this frame's, with the animated objects placed at
    /// `nextFrame`'s time (in State::aheadInstances[sequence % 2]).
    std::span<const gi::MeshInstance> placeForNextFrame(const RgbdFrame& nextFrame, std::uint64_t sequence);
    void lightsMoved();
    void instancesChanged();
    void rebuildDifferential();
    void checkObjectIndex(std::size_t object) const;
    std::string sourceName() const;
    // The stages of render(), in order (docs/ARCHITECTURE.md: capture -> filter -> pose -> VALs -> GI ->
    // composite; filter and pose ran in prepare()). FrameWork carries one frame's state between them.
    struct FrameWork;
    void beginFrame(FrameWork& w);
    void passThrough(FrameWork& w);
    void makeVals(FrameWork& w);
    gi::CpuValGenerator& generateCpuVals(std::uint64_t sequence, const RgbdFrame& frame, const cv::Mat& depth,
                                         const Pose& pose, std::span<const gi::MeshInstance> instances, int threads);
    void estimateRoomLight(FrameWork& w);
    void startDifferential(FrameWork& w);
    void finishDifferential(FrameWork& w);
    void addVirtualBounceVals(FrameWork& w);
    void explainGiActivity(FrameWork& w);
    void makeNextFrameVals(FrameWork& w, NextFrame* next);
    void renderGi(FrameWork& w);
    void renderGiFromCpuVals(FrameWork& w, const gi::ViewParameters& view);
    void composite(FrameWork& w);
    void renderReferenceIndirect(FrameWork& w);
    void renderBruteForce(FrameWork& w);
    void drawOverlays(FrameWork& w);
    void drawErrorVsBruteForce(FrameWork& w);
    void compositeWithoutGi(FrameWork& w);
    void collectStageTimes(FrameWork& w);
    struct State;
    std::unique_ptr<State> state_;
    std::unique_ptr<render::Renderer> renderer_;
    PipelineOptions options_;
    render::GiSettings gi_;
};

} // namespace lightskin::mr
