#pragma once
// The pipeline as an engine embeds it: a Session owns a scene, a FramePipeline and (optionally) a frame budget,
// takes frames from a capture::FrameSource or the host's memory, and draws into the host's framebuffer or texture.
// GL: create, submit/process/processNext, render and destruction need the same GL 4.5 core context current on the
// calling thread (the host owns it); the GL state is left as found (gl::StateGuard). One thread at a time per
// session. Errors: lightskin::Error naming the file, frame or key; the session stays usable after one.
// Usage in ten lines, threading and errors: docs/PLUGIN.md.

#include <lightskin/capture/FrameSource.h>
#include <lightskin/mr/FrameBudget.h>
#include <lightskin/mr/FramePipeline.h>

#include <glm/mat4x4.hpp>

#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>

namespace lightskin::mr {

/// The scene: a scene file (docs/SCENE_FORMAT.md), or the same JSON as text with the folder that
/// relative mesh paths are resolved against.
struct SceneInput {
    std::filesystem::path file;       ///< used when `json` is empty
    std::string json;                 ///< in-memory scene text
    std::filesystem::path baseFolder; ///< for `json`: where relative paths point
    static SceneInput fromFile(std::filesystem::path path) { return {std::move(path), {}, {}}; }
    static SceneInput fromJson(std::string text, std::filesystem::path base) {
        return {{}, std::move(text), std::move(base)};
    }
};

/// A frame in host memory. Read only during submit(); the session keeps no pointer to it.
struct HostFrame {
    const std::uint8_t* rgb = nullptr; ///< width x height x 3 bytes, R G B order, sRGB-encoded, top row first
    std::size_t rgbRowBytes = 0;       ///< 0 = width * 3
    /// Optional: width x height depth values along the optical axis (z, not ray length) in units of
    /// depthScaleMetres, 0 = missing, registered to the colour image (same size and intrinsics).
    /// Without depth there are no VALs (no GI) and no occlusion by real geometry.
    const std::uint16_t* depth = nullptr;
    std::size_t depthRowBytes = 0; ///< 0 = width * 2
    double depthScaleMetres = 0.001;
    CameraIntrinsics intrinsics; ///< must equal the session's camera
    double timestampSeconds = std::numeric_limits<double>::quiet_NaN();
    /// The host's pose of the colour camera in the scene's world (OpenCV camera frame: x right,
    /// y down, z forward; metres). Used with PoseMode::GroundTruth ("the host tracks"); without
    /// it such a frame has no pose and passes through unchanged.
    std::optional<Pose> world_T_camera;
};

enum class RenderContent : std::uint8_t {
    /// The lit virtual objects only (sRGB-encoded colour, alpha 1), drawn over what the target holds;
    /// uncovered pixels are left untouched.
    VirtualOnly,
    /// The composite (camera image + virtual objects, occluded by real depth) over the whole viewport.
    CompositeOverCamera,
};

/// Where render() draws. The image is drawn upright (camera row 0 at the top of the viewport).
struct RenderTarget {
    std::uint32_t framebuffer = 0; ///< GL framebuffer to draw into (0 = the default framebuffer) ...
    std::uint32_t texture = 0;     ///< ... or, when non-zero, level 0 of this colour-renderable GL_TEXTURE_2D
    int x = 0, y = 0;              ///< viewport origin in target pixels (GL: from the bottom left)
    int width = 0, height = 0;     ///< viewport size; 0 = the camera's size
    RenderContent content = RenderContent::VirtualOnly;
    /// VirtualOnly into a framebuffer with a depth buffer: test against and write its depth, with
    /// the virtual depth projected by projection(nearMetres, farMetres): a host that draws with
    /// that projection and viewMatrix() gets its geometry and the virtual objects mutually occluded.
    bool depthTest = false;
    double nearMetres = 0.05, farMetres = 20.0;
};

/// What a frame did (valid until the next frame).
struct FrameReport {
    std::int64_t frameIndex = -1;
    double timestampSeconds = std::numeric_limits<double>::quiet_NaN();
    tracking::TrackingState trackingState = tracking::TrackingState::Lost;
    std::optional<Pose> world_T_camera;
    std::uint32_t valCount = 0;
    std::int64_t coveredPixels = 0;
    double totalMs = 0.0;                               ///< wall clock of the whole frame
    QualitySettings settings;                           ///< the GI settings this frame ran with (the budget's knobs)
    gi::Technique technique = gi::Technique::LightSkin; ///< the technique this frame ran
    gi::Backend backend = gi::Backend::Gl;              ///< and its backend
    bool budgetActive = false;
    double budgetMs = 0.0;      ///< 0 without a budget
    double predictedMs = 0.0;   ///< the budget's prediction for this frame (before it ran)
    double expectedError = 0.0; ///< the budget's error model for `settings`
};

struct SessionOptions {
    /// Pose mode, views, GI toggle, ... (compare is off: embedding hosts draw one image).
    PipelineOptions pipeline = [] {
        PipelineOptions o;
        o.compare = false;
        return o;
    }();
    /// Frame budget in ms (> 0 overrides the scene's gi.budgetMs; 0 = the scene's, if any).
    double budgetMs = 0.0;
    /// Multi-scale PRT's precompute cache folder, overriding the scene's gi.multiscalePrt cacheDir (and its
    /// "cache": false); relative paths are relative to the working directory. Unset = the scene's.
    std::optional<std::filesystem::path> prtCacheDirectory;
    BudgetOptions budget; ///< its budgetMs is ignored (see above)
    /// Tests and calibration: the costs the budget observes per frame instead of the wall clock
    /// (default: G-buffer + GI stage and the rest of FrameOutput::cpuTimes).
    std::function<StageCosts(const QualitySettings&, const FrameStats&, const FrameOutput&)>
        costMeter; /// Source-fed sessions: read frame n+1 and run its depth filter and pose on a worker thread while
    /// processNext() renders frame n (FramePipeline::prepare; the images are the same bit for bit). The
    /// worker reads up to two frames ahead of the caller, so a live camera's frame is up to two frames older; a
    /// source error is reported at its frame, after which every processNext() reports it again.
    /// pipeline.poseMode must not change while the session lives. With the CPU backend and no frame budget it
    /// also computes frame n+1's VALs and GI stages 0-4 on a worker while frame n reads back and composites
    /// (FramePipeline's GI ahead; FrameOutput::giComputedAhead), again with the same images.
    bool prefetch = false;
};

class Session {
public:
    /// Host-fed session for frames of `camera` (submit()). Throws lightskin::Error on a bad scene
    /// (naming the file or key) or invalid intrinsics.
    static std::unique_ptr<Session> create(const SessionOptions& options, const SceneInput& scene,
                                           const CameraIntrinsics& camera);
    /// Source-fed session (processNext()); takes the source.
    static std::unique_ptr<Session> create(const SessionOptions& options, const SceneInput& scene,
                                           std::unique_ptr<capture::FrameSource> source);
    /// Session for frames the caller reads from a source it keeps (process()), e.g. to record them too.
    static std::unique_ptr<Session> create(const SessionOptions& options, const SceneInput& scene,
                                           const capture::FrameSourceInfo& info);
    ~Session();
    Session(const Session&) = delete;
    Session& operator=(const Session&) = delete;

    /// Source-fed: runs the next frame of the source; false at its end. Throws on bad input.
    bool processNext();
    /// Host-fed: runs one frame from host memory. Throws lightskin::Error (naming the frame) when
    /// pointers are missing or the intrinsics differ from the session's camera.
    void submit(const HostFrame& frame);
    /// Runs one frame (either kind of session; the frame's intrinsics must be the session's).
    void process(const RgbdFrame& frame);

    /// Draws the last frame into the host's target (see RenderTarget). Throws lightskin::Error on a
    /// bad target (incomplete framebuffer, VirtualOnly with the pipeline's compare on, ...).
    void render(const RenderTarget& target);

    const FrameReport& report() const noexcept { return report_; }
    /// The last frame's images (withGi: BGR composite) and all per-stage timings.
    const FrameOutput& output() const noexcept { return output_; }
    /// Source-fed sessions: the frame processNext() read last (as the source delivered it).
    const RgbdFrame& sourceFrame() const noexcept { return *current_; }

    const CameraIntrinsics& camera() const noexcept { return camera_; }
    /// GL clip_T_camera for this camera (render::clipFromCamera: OpenCV camera frame in, column-major).
    glm::mat4 projection(double nearMetres, double farMetres) const;
    /// camera_T_world of the last frame's pose (OpenCV camera frame), identity without a pose.
    glm::mat4 viewMatrix() const;

    FramePipeline& pipeline() noexcept { return *pipeline_; }
    /// Saves the room memory's model (FramePipeline::saveRoomModel) once the source's prefetch has stopped: call it
    /// when done with the source, since frames the prefetch read ahead are dropped (a later processNext() goes on
    /// after them). Throws lightskin::Error naming the file.
    void saveRoomModel(const std::filesystem::path& file);
    /// Replaces the room memory's model by a saved one (FramePipeline::loadRoomModel), after stopping the prefetch as
    /// saveRoomModel() does. Throws lightskin::Error naming the file; the model then stays as it was.
    void loadRoomModel(const std::filesystem::path& file);
    const FramePipeline& pipeline() const noexcept { return *pipeline_; }
    /// The virtual content as it is now (FramePipeline::scene()): object and light names, counts, placements.
    const render::Scene& scene() const noexcept { return pipeline_->scene(); }

    // Moving content (FramePipeline's calls; docs/PLUGIN.md, "Moving content"). Each checks its input and
    // throws lightskin::Error naming the object or light and the cause, changing nothing. Placements and
    // lights take effect from the next frame; visible, add and remove need the GL context current.
    void setObjectTransform(std::size_t object, const glm::mat4& world_T_model);
    void setObjectVisible(std::size_t object, bool visible);
    void setObjectMaterial(std::size_t object, const render::MaterialOverride& material);
    void setLight(std::size_t light, const glm::vec3& position, const glm::vec3& direction, const glm::vec3& power);
    /// Returns the new object's index (the last).
    std::size_t addObject(render::SceneObject object);
    void removeObject(std::size_t object);
    /// Sets the frame budget (ms > 0; throws lightskin::Error otherwise), starting budget mode
    /// if the session had none (not with the technique "none"). Takes effect from the next frame.
    void setBudgetMs(double budgetMs);
    /// The frame budget, or nullptr without one.
    FrameBudget* budget() noexcept { return budget_ ? &*budget_ : nullptr; }
    capture::FrameSource* source() noexcept { return source_.get(); }

private:
    Session() = default;
    /// Waits for the GI ahead (it reads a frame of the prefetch) and stops the prefetch's worker (it uses the source
    /// and updates the pipeline's room memory); frames it read ahead are dropped.
    void stopReadAhead();
    /// process() on the pipeline's front result `prepared` (nullptr: the pipeline runs the front itself);
    /// `nextFrame`: the prefetch's next frame, for the pipeline's GI ahead (nullptr: none).
    void processWith(const RgbdFrame& frame, const PreparedFrame* prepared, NextFrame* nextFrame);
    static std::unique_ptr<Session> createWith(const SessionOptions& options, const SceneInput& scene,
                                               const capture::FrameSourceInfo& info);
    struct Gl;
    std::unique_ptr<capture::FrameSource> source_;
    std::unique_ptr<FramePipeline> pipeline_;
    std::unique_ptr<Gl> gl_;
    std::optional<FrameBudget> budget_;
    SessionOptions options_;
    CameraIntrinsics camera_;
    QualitySettings applied_;
    std::optional<FrameStats> lastStats_;
    RgbdFrame frame_;
    const RgbdFrame* current_ = &frame_;              // the frame of output_ (frame_, or a prefetch slot)
    std::unique_ptr<class FramePrefetcher> prefetch_; // SessionOptions::prefetch, started by processNext()
    FrameOutput output_;
    FrameReport report_;
};

} // namespace lightskin::mr
