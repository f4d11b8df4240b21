#pragma once
// The replay report: report.json (every frame's pose, tracking state, VAL counts and stage times)
// and report.md (summary, side-by-side images, per-stage timings per frame, pose track).

#include <lightskin/mr/FramePipeline.h>

#include <nlohmann/json_fwd.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace lightskin::apps {

struct ReportFrame {
    std::int64_t index = 0;
    std::string trackingState;
    std::string trackingReason;
    std::optional<Pose> world_T_camera;
    /// Pose error against the recording's ground truth (frames with both): translation distance,
    /// metres, and relative rotation angle, degrees; < 0 when not available.
    double poseErrorMetres = -1.0, poseErrorDegrees = -1.0;
    std::uint32_t valCount = 0;    ///< VALs from depth
    bool giActive = false;         ///< GI lit this frame (mr::FrameOutput::giActive)
    std::string giInactiveCause;   ///< why not, when !giActive
    std::int64_t rsmValCount = -1; ///< gi.virtualBounce: VALs from the virtual lights' RSMs, else < 0
    std::int64_t valsDropped = -1; ///< gi.virtualBounce: VALs that did not fit the merged set, else < 0
    std::vector<gl::StageTime> cpuTimes, gpuTimes;
    double totalMs = 0.0;
    std::int64_t vplSegments = -1;   ///< --view vpl: vertex VPLs drawn, else < 0
    std::int64_t vplNonFinite = -1;  ///< --view vpl: vertices with a non-finite VPL, else < 0
    double errorVsBruteForce = -1.0; ///< --view error: mean relative error of the technique's indirect light, else < 0
    int giReused = -1;               ///< --adaptive: 1 = static content, VPLs reused; 0 = recomputed; else < 0
    float giChangeMeasure = -1.0f;   ///< --adaptive with a tolerance: LightSkinChoice::staticChangeBound, else < 0
    std::int64_t volumeVoxelsDropped = -1; ///< imperfect volumes: voxels dropped for want of slots, else < 0
    std::int64_t linearNanPixels = 0;      ///< pixels of the linear composite with a NaN channel (mr::FrameOutput)
    std::int64_t linearInfPixels = 0;      ///< ... with an infinite channel (and no NaN)
    std::string linearImage;               ///< --linear-out: linear composite written for this frame, or empty
    std::string linearIndirectImage;       ///< --linear-out: linear indirect-only image, or empty
    /// Recordings with synth/present/ (the objects really in the room): the error of the composite
    /// against it in linear light over the pixels the objects affect (the truth differs from the
    /// camera image, or virtual content covers the pixel), with and without the differential.
    /// `real`: the same over the affected pixels that no virtual content covers (where only the
    /// differential can change the composite).
    struct PresentError {
        std::int64_t pixels = -1;
        double maeWith = 0.0, maeWithout = 0.0;   ///< mean |composite - truth|, linear, over pixels and channels
        double rmseWith = 0.0, rmseWithout = 0.0; ///< root mean square of the same
    };
    PresentError present, presentReal;
    std::string presentImage;  ///< truth | with differential | without, or empty
    std::string image;         ///< PNG written for this frame (relative to the output folder), or empty
    std::string compareImage;  ///< side-by-side PNG, or empty
    std::string giSettings;    ///< --budget-ms: the settings the frame budget chose (mr::describe), else empty
    double predictedMs = -1.0; ///< --budget-ms: the budget's prediction for the frame, else < 0
    /// A scene light of type estimated: the room's light (mr::FrameOutput::lightEstimate), whether this frame
    /// fitted it, what became the direct light and the estimate's thread CPU time (ms); unset otherwise.
    std::optional<roomlight::LightEstimate> lightEstimate;
    bool roomLightFitted = false;
    mr::EstimatedDirectLight estimatedLight;
    double roomLightCpuMs = -1.0;
};

/// report.json's "lightEstimate" of one frame (docs/ROOMLIGHT.md, "In the pipeline"): the estimate in the camera's
/// units and the world frame ("sh", "dominant", "residual", "state", "problem", ...) and the light drawn from it
/// ("direct", in the renderer's watts).
nlohmann::json lightEstimateJson(const roomlight::LightEstimate& estimate, bool fitted,
                                 const mr::EstimatedDirectLight& direct, double cpuMs);

struct ReportSummary {
    std::string recording, scene, renderer, technique, poseMode, video, videoCodec, command;
    /// The backend the technique ran on ("gl", "cpu") and why (gi::toString(gi::BackendReason)), as the
    /// pipeline chose it when it was created.
    std::string giBackend, giBackendReason;
    /// What the side-by-side images show, left and right (their labels), and the report's heading for
    /// them: "with GI" only when the left half is the composite with GI (--view final).
    std::string compareLeft, compareRight, compareTitle = "With GI / without GI (the paper's figure 4)";
    std::int64_t framesRead = 0;
    std::optional<std::int64_t> framesInSource;
    bool interrupted = false;
    /// Why the run stopped early with an error (the frames, images and video before it are kept),
    /// or empty. report.json's "status" is "failed" then, else "interrupted" or "complete".
    std::string failure;
    double wallSeconds = 0.0;
    /// Wall time from the end of the first frame to the end of the last, per frame (the setup and the first
    /// frame's one-off costs left out: the replay's steady rate); 0 with fewer than 2 frames.
    double steadyMsPerFrame = 0.0;
    /// Technique multiscale-prt: its prepare() (precompute or cache load) before the first frame, else nullopt.
    std::optional<gi::PrtPrepareStats> prtPrepare;
};

/// Writes report.json and report.md into `folder`. Throws lightskin::Error when a file cannot be written.
void writeReplayReport(const std::filesystem::path& folder, const ReportSummary& summary,
                       const std::vector<ReportFrame>& frames);

} // namespace lightskin::apps
