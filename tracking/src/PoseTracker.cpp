#include <lightskin/core/Error.h>
#include <lightskin/tracking/PoseTracker.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cmath>
#include <numbers>

namespace lightskin::tracking {

const char* toString(TrackingState state) noexcept {
    switch (state) {
    case TrackingState::Tracking:
        return "tracking";
    case TrackingState::Held:
        return "held";
    case TrackingState::Lost:
        return "lost";
    case TrackingState::DepthTracked:
        return "depth-tracked";
    }
    return "?";
}

namespace {
using Clock = std::chrono::steady_clock;
double millisecondsSince(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

bool sameCamera(const CameraIntrinsics& a, const CameraIntrinsics& b) {
    return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy &&
           a.distortion == b.distortion;
}

cv::Matx33d cameraMatrix(const CameraIntrinsics& k) { return {k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0}; }
} // namespace

struct PoseTracker::Impl {
    TagWorld world;
    TrackerSettings settings;
    TagDetector detector;
    PoseFilter filter;

    std::vector<TagDetection> detections;
    PoseMeasurement measurement;
    cv::Mat grey;
    cv::Mat undistorted;
    cv::Mat mapX, mapY;
    std::optional<CameraIntrinsics> mapIntrinsics;
    std::vector<cv::Point2d> cornerBuffer;

    TrackingState state = TrackingState::Lost;
    int framesWithoutMeasurement = 0;
    double lastMeasurementTimestamp = std::numeric_limits<double>::quiet_NaN();

    Impl(TagWorld w, const TrackerSettings& s, TagDetector d)
        : world(std::move(w))
        , settings(s)
        , detector(std::move(d))
        , filter(s.filter) {}
};

PoseTracker PoseTracker::create(TagWorld world, const TrackerSettings& settings) {
    if (settings.maxHeldFrames < 0) throw Error("max_held_frames", std::nullopt, "must be >= 0");
    if (!(settings.maxReprojectionErrorPx > 0.0)) throw Error("max_reprojection_error_px", std::nullopt, "must be > 0");
    if (!(settings.ambiguityRatio >= 1.0)) throw Error("ambiguity_ratio", std::nullopt, "must be >= 1");
    if (!(settings.maxWorldCornerStdPx > 0.0)) throw Error("max_world_corner_std_px", std::nullopt, "must be > 0");
    if (!(settings.historyRatio >= 1.0)) throw Error("history_ratio", std::nullopt, "must be >= 1");
    if (!(settings.nominalFrameIntervalSeconds > 0.0))
        throw Error("nominal_frame_interval", std::nullopt, "must be > 0 seconds");
    if (!(settings.filter.minCutoffHz > 0.0 && settings.filter.derivativeCutoffHz > 0.0 &&
          settings.filter.betaTranslation >= 0.0 && settings.filter.betaRotation >= 0.0))
        throw Error("filter", std::nullopt, "cutoffs must be > 0 Hz and betas >= 0");
    DetectorSettings detectorSettings = settings.detector;
    detectorSettings.family = world.family();
    TagDetector detector = TagDetector::create(detectorSettings);
    TrackerSettings stored = settings;
    stored.detector = detectorSettings;
    return PoseTracker(std::make_unique<Impl>(std::move(world), stored, std::move(detector)));
}

PoseTracker::PoseTracker(std::unique_ptr<Impl> impl)
    : impl_(std::move(impl)) {}
PoseTracker::PoseTracker(PoseTracker&&) noexcept = default;
PoseTracker& PoseTracker::operator=(PoseTracker&&) noexcept = default;
PoseTracker::~PoseTracker() = default;

const TagWorld& PoseTracker::world() const noexcept { return impl_->world; }
const TrackerSettings& PoseTracker::settings() const noexcept { return impl_->settings; }
const std::vector<TagDetection>& PoseTracker::lastDetections() const noexcept { return impl_->detections; }

void PoseTracker::reset() {
    impl_->state = TrackingState::Lost;
    impl_->framesWithoutMeasurement = 0;
    impl_->lastMeasurementTimestamp = std::numeric_limits<double>::quiet_NaN();
    impl_->filter.reset();
}

void PoseTracker::trackInto(const RgbdFrame& frame, TrackingResult& out) {
    if (!frame.hasColour()) throw Error("tracking", frame.index, "the frame has no colour image");
    trackImpl(frame.colour, frame.colourIntrinsics, frame.colourTimestampSeconds, frame.index, &frame, out);
}

TrackingResult PoseTracker::track(const RgbdFrame& frame) {
    TrackingResult out;
    trackInto(frame, out);
    return out;
}

void PoseTracker::trackImageInto(const cv::Mat& image, const CameraIntrinsics& intrinsics, double timestampSeconds,
                                 std::int64_t frameIndex, TrackingResult& out) {
    trackImpl(image, intrinsics, timestampSeconds, frameIndex, nullptr, out);
}

TrackingResult PoseTracker::fromGroundTruth(const RgbdFrame& frame) {
    TrackingResult out;
    out.frameIndex = frame.index;
    out.reprojectionErrorPx = std::numeric_limits<double>::quiet_NaN();
    if (frame.groundTruth_world_T_camera) {
        out.state = TrackingState::Tracking;
        out.world_T_camera = frame.groundTruth_world_T_camera;
        out.measured_world_T_camera = frame.groundTruth_world_T_camera;
    } else {
        out.state = TrackingState::Lost;
        out.framesWithoutMeasurement = 1;
        out.reason = "no ground truth";
    }
    return out;
}

void PoseTracker::trackImpl(const cv::Mat& image, const CameraIntrinsics& intrinsics, double timestampSeconds,
                            std::int64_t frameIndex, const RgbdFrame* depthFrame, TrackingResult& out) {
    Impl& s = *impl_;
    const TrackerSettings& settings = s.settings;
    const Clock::time_point start = Clock::now();

    if (!intrinsics.isValid())
        throw Error("tracking", frameIndex, "invalid colour intrinsics: " + intrinsics.describe());
    if (image.empty() || image.cols != intrinsics.width || image.rows != intrinsics.height)
        throw Error("tracking", frameIndex,
                    "image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                        " but the intrinsics are " + std::to_string(intrinsics.width) + "x" +
                        std::to_string(intrinsics.height));
    if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3 && image.channels() != 4))
        throw Error("tracking", frameIndex, "the image must be 8-bit grey, BGR or BGRA");

    out.frameIndex = frameIndex;
    out.measured_world_T_camera.reset();
    out.tagsUsed.clear();
    out.unknownTags.clear();
    out.rejectedTags.clear();
    out.reprojectionErrorPx = std::numeric_limits<double>::quiet_NaN();
    out.ambiguityRatio = std::numeric_limits<double>::quiet_NaN();
    out.ambiguous = false;
    out.resolvedByHistory = false;
    out.poseJumped = false;
    out.depthRefined = false;
    out.uncertainty = PoseUncertainty{};
    out.reason = "";

    // Greyscale, and the undistorted image when asked for.
    const cv::Mat* grey = &image;
    if (image.channels() != 1) {
        cv::cvtColor(image, s.grey, image.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
        grey = &s.grey;
    }
    const bool distorted = intrinsics.hasDistortion();
    if (distorted && settings.undistortion == Undistortion::Image) {
        if (!s.mapIntrinsics || !sameCamera(*s.mapIntrinsics, intrinsics)) {
            cv::initUndistortRectifyMap(cameraMatrix(intrinsics), intrinsics.distortion, cv::noArray(),
                                        cameraMatrix(intrinsics), cv::Size(intrinsics.width, intrinsics.height),
                                        CV_16SC2, s.mapX, s.mapY);
            s.mapIntrinsics = intrinsics;
        }
        cv::remap(*grey, s.undistorted, s.mapX, s.mapY, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(255));
        grey = &s.undistorted;
    }
    out.timing.preprocessMs = millisecondsSince(start);

    const Clock::time_point detectStart = Clock::now();
    s.detector.detectInto(*grey, s.detections);
    out.timing.detectMs = millisecondsSince(detectStart);

    const Clock::time_point poseStart = Clock::now();
    if (distorted && settings.undistortion == Undistortion::Corners && !s.detections.empty()) {
        s.cornerBuffer.resize(s.detections.size() * 4);
        for (std::size_t i = 0; i < s.detections.size(); ++i)
            for (std::size_t c = 0; c < 4; ++c)
                s.cornerBuffer[i * 4 + c] = {s.detections[i].corners[c].x, s.detections[i].corners[c].y};
        cv::Mat points(static_cast<int>(s.cornerBuffer.size()), 1, CV_64FC2, s.cornerBuffer.data());
        cv::undistortPoints(points, points, cameraMatrix(intrinsics), intrinsics.distortion, cv::noArray(),
                            cameraMatrix(intrinsics));
        for (std::size_t i = 0; i < s.detections.size(); ++i)
            for (std::size_t c = 0; c < 4; ++c)
                s.detections[i].corners[c] = {s.cornerBuffer[i * 4 + c].x, s.cornerBuffer[i * 4 + c].y};
    }

    estimatePoseInto(s.detections, s.world, intrinsics, s.measurement, settings.maxReprojectionErrorPx);
    out.unknownTags = s.measurement.unknownTags;
    out.rejectedTags = s.measurement.rejectedTags;

    const bool havePrevious = s.state != TrackingState::Lost && s.filter.initialised();
    std::optional<Pose> accepted;
    if (!s.measurement.valid()) {
        out.reason = s.detections.empty() ? "no tags detected" : "no tag of the world detected";
    } else {
        const auto& candidates = s.measurement.candidates;
        out.ambiguityRatio = s.measurement.ambiguityRatio;
        out.ambiguous = out.ambiguityRatio < settings.ambiguityRatio;
        std::size_t chosen = 0;
        // A pose that cannot place the world's tags is not reported as tracking.
        const auto poorlyDetermined = [&](const Pose& pose, double rmsErrorPx) {
            if (!std::isfinite(settings.maxWorldCornerStdPx)) return false;
            out.uncertainty = estimateUncertainty(pose, s.detections, s.world, intrinsics, std::max(rmsErrorPx, 0.1),
                                                  s.measurement.tagsUsed);
            if (out.uncertainty.worldCornerStdPx <= settings.maxWorldCornerStdPx) return false;
            out.reprojectionErrorPx = rmsErrorPx;
            out.reason = "pose poorly determined (world corners' std above maxWorldCornerStdPx): not accepted";
            return true;
        };
        const double maxJump = settings.maxJumpDegrees * std::numbers::pi / 180.0;
        if (havePrevious) {
            const Pose& previous = s.filter.current();
            if (out.ambiguous && out.ambiguityRatio < settings.historyRatio && candidates.size() == 2 &&
                candidates[1].rmsErrorPx <= settings.maxReprojectionErrorPx &&
                Pose::rotationAngleBetween(previous, candidates[1].world_T_camera) <
                    Pose::rotationAngleBetween(previous, candidates[0].world_T_camera)) {
                chosen = 1;
                out.resolvedByHistory = true;
            }
            if (poorlyDetermined(candidates[chosen].world_T_camera, candidates[chosen].rmsErrorPx)) {
                chosen = candidates.size();
            } else if (Pose::rotationAngleBetween(previous, candidates[chosen].world_T_camera) > maxJump) {
                if (out.ambiguous) {
                    out.reason = "ambiguous pose far from the previous one (possible flip): rejected";
                    chosen = candidates.size();
                } else {
                    out.poseJumped = true;
                    s.filter.reset();
                }
            }
        }
        if (!havePrevious && poorlyDetermined(candidates[chosen].world_T_camera, candidates[chosen].rmsErrorPx))
            chosen = candidates.size();
        if (chosen < candidates.size()) {
            out.reprojectionErrorPx = candidates[chosen].rmsErrorPx;
            if (candidates[chosen].rmsErrorPx > settings.maxReprojectionErrorPx) {
                out.reason = "reprojection error above maxReprojectionErrorPx";
            } else {
                accepted = candidates[chosen].world_T_camera;
            }
        }
    }

    if (accepted && settings.useDepth && depthFrame != nullptr && depthFrame->hasDepth() &&
        depthFrame->registration == DepthRegistration::RegisteredToColour && !distorted &&
        depthFrame->depth.size() == image.size() && s.measurement.tagsUsed.size() == 1) {
        const int id = s.measurement.tagsUsed.front();
        for (const TagDetection& detection : s.detections) {
            if (detection.id != id) continue;
            Pose refined = *accepted;
            if (refinePoseWithDepth(depthFrame->depth, depthFrame->depthScaleMetres, intrinsics, detection,
                                    *s.world.find(id), refined)) {
                accepted = refined;
                out.depthRefined = true;
            }
            break;
        }
    }

    if (accepted) {
        // Corner noise: the measured RMS, but not below 0.1 px (a perfect fit of 8 numbers by 6
        // parameters underestimates the noise; 0.1 px is what good detections achieve).
        out.uncertainty = estimateUncertainty(*accepted, s.detections, s.world, intrinsics,
                                              std::max(out.reprojectionErrorPx, 0.1), s.measurement.tagsUsed);
        double dt = settings.nominalFrameIntervalSeconds * (s.framesWithoutMeasurement + 1);
        if (std::isfinite(timestampSeconds) && std::isfinite(s.lastMeasurementTimestamp) &&
            timestampSeconds > s.lastMeasurementTimestamp)
            dt = timestampSeconds - s.lastMeasurementTimestamp;
        if (!havePrevious) s.filter.reset();
        out.world_T_camera = s.filter.update(*accepted, dt);
        out.measured_world_T_camera = accepted;
        out.tagsUsed = s.measurement.tagsUsed;
        s.state = TrackingState::Tracking;
        s.framesWithoutMeasurement = 0;
        s.lastMeasurementTimestamp = timestampSeconds;
    } else {
        ++s.framesWithoutMeasurement;
        if (s.state != TrackingState::Lost && s.framesWithoutMeasurement <= settings.maxHeldFrames) {
            s.state = TrackingState::Held;
        } else {
            s.state = TrackingState::Lost;
            s.filter.reset();
        }
        if (s.state == TrackingState::Held) {
            out.world_T_camera = s.filter.current();
        } else {
            out.world_T_camera.reset();
        }
    }
    out.state = s.state;
    out.framesWithoutMeasurement = s.framesWithoutMeasurement;
    out.timing.poseMs = millisecondsSince(poseStart);
    out.timing.totalMs = millisecondsSince(start);
}

} // namespace lightskin::tracking
