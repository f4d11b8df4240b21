#include <lightskin/core/Error.h>
#include <lightskin/roommodel/RoomMemory.h>
#include <lightskin/roommodel/RoomModelFile.h>

#include <glm/gtc/quaternion.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/rgbd/depth.hpp>

#include <chrono>
#include <cmath>
#include <optional>
#include <vector>

namespace lightskin::roommodel {

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

Pose poseFromCv(const cv::Mat& rt) {
    glm::dmat4 m(1.0);
    for (int row = 0; row < 4; ++row)
        for (int col = 0; col < 4; ++col) m[col][row] = rt.at<double>(row, col);
    return Pose::fromMatrix(m);
}

void toCv(const Pose& pose, cv::Mat& rt) {
    rt.create(4, 4, CV_64FC1);
    const glm::dmat4 m = pose.matrix();
    for (int row = 0; row < 4; ++row)
        for (int col = 0; col < 4; ++col) rt.at<double>(row, col) = m[col][row];
}

/// D^s for a rigid offset near identity: the rotation slerped from identity by s, the translation scaled by s.
Pose fractionOf(const Pose& offset, double s) {
    const glm::dquat rotation = glm::slerp(glm::dquat(1.0, 0.0, 0.0, 0.0), offset.rotation(), s);
    return Pose(rotation, offset.translation() * s);
}

/// RoomMemoryStats::constraintRatio of the view: depth (CV_32FC1) and normals (CV_32FC3), camera frame.
double constraintRatioOf(const cv::Mat& depth, const cv::Mat& normals, const CameraIntrinsics& k) {
    // Every second pixel both ways: a quarter of the work, the same spread of points and normals.
    constexpr int kStep = 2;
    cv::Vec3d centre(0.0, 0.0, 0.0);
    int count = 0;
    const auto pointAt = [&](int u, int v) {
        const double z = depth.at<float>(v, u);
        return cv::Vec3d((u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z);
    };
    for (int v = 0; v < depth.rows; v += kStep)
        for (int u = 0; u < depth.cols; u += kStep)
            if (depth.at<float>(v, u) > 0.0f) {
                centre += pointAt(u, v);
                ++count;
            }
    if (count < 6) return 0.0;
    centre /= double(count);
    double meanDistance = 0.0;
    for (int v = 0; v < depth.rows; v += kStep)
        for (int u = 0; u < depth.cols; u += kStep)
            if (depth.at<float>(v, u) > 0.0f) meanDistance += cv::norm(pointAt(u, v) - centre);
    meanDistance /= double(count);
    cv::Matx66d normal = cv::Matx66d::zeros();
    for (int v = 0; v < depth.rows; v += kStep)
        for (int u = 0; u < depth.cols; u += kStep) {
            if (depth.at<float>(v, u) <= 0.0f) continue;
            const cv::Vec3d n(normals.at<cv::Vec3f>(v, u));
            const cv::Vec3d p = (pointAt(u, v) - centre) / meanDistance;
            const cv::Vec3d r = p.cross(n);
            const cv::Vec<double, 6> row(r[0], r[1], r[2], n[0], n[1], n[2]);
            normal += row * row.t();
        }
    cv::Vec<double, 6> eigenvalues; // descending; fixed-size: no allocation per frame
    cv::eigen(normal, eigenvalues);
    const double largest = eigenvalues[0], smallest = eigenvalues[5];
    return largest > 0.0 ? smallest / largest : 0.0;
}

/// Depth holds no negative values: every non-zero pixel is a valid one.
double validFraction(const cv::Mat& depth) { return double(cv::countNonZero(depth)) / double(depth.total()); }

} // namespace

struct RoomMemory::Impl {
    explicit Impl(RoomModel m)
        : model(std::move(m)) {}
    RoomMemorySettings settings;
    RoomModel model;
    cv::Ptr<cv::rgbd::ICPOdometry> odometry;
    CameraIntrinsics odometryIntrinsics; // the camera matrix odometry was made for
    // Scratch, sized on the first frame.
    cv::Mat subsampled, modelDepth, modelNormals, rt, initialRt;
    cv::Mat processed; // the frame's depth at the processing size (may share `subsampled` or the input)
    CameraIntrinsics processedIntrinsics;
    cv::Mat trackingScratch, tracked; // the same at the tracking size
    CameraIntrinsics trackedIntrinsics;
    // Pose history.
    std::optional<Pose> lastOutput;   // the previous frame's output pose
    std::optional<Pose> outputBefore; // the one before it (for the constant-velocity prediction)
    bool sinceTagsFromDepth = false;  // the pose has come from depth (or was held by us) since the last tag pose
    int depthRun = 0;                 // DepthTracked frames in a row
    bool expired = false;             // depth tracking ran maxFrames: Lost until the tags return
    bool failed = false;              // ICP failed since the last tag frame: no more until the tags return
    Pose blendOffset;                 // D = tag^-1 * depth at the return to the tags
    int blendLeft = 0;                // frames of the blend still to go
    RoomMemoryStats stats;

    void prepareDepth(const cv::Mat& depthMetres, const CameraIntrinsics& intrinsics);
    std::optional<Pose> trackFrom(const Pose& world_T_previous);
    void onTagFrame(tracking::TrackingResult& result);
    void onNoTagFrame(tracking::TrackingResult& result);
    void forgetPoses();
};

/// `depth` subsampled by an integer factor to at most `width` pixels wide, into `out` (or shared when it fits).
void subsampleInto(const cv::Mat& depth, const CameraIntrinsics& intrinsics, int width, cv::Mat& scratch, cv::Mat& out,
                   CameraIntrinsics& outIntrinsics) {
    const int factor = std::max(1, (intrinsics.width + width - 1) / width);
    if (factor == 1) {
        out = depth;
        outIntrinsics = intrinsics;
        return;
    }
    const int w = intrinsics.width / factor, h = intrinsics.height / factor;
    // Every factor-th pixel, not an average: averaging depth across an edge invents surfaces between foreground
    // and background. Pixel u of the result is pixel factor * u of the input (cv::resize's INTER_NEAREST at an
    // integer factor), so the principal point is divided as it is, not as CameraIntrinsics::scaledTo's area
    // convention ((c + 0.5) s - 0.5): that one is a quarter pixel off here, 4 mm of pose at 2 m.
    cv::resize(depth, scratch, cv::Size(w, h), 0.0, 0.0, cv::INTER_NEAREST);
    out = scratch;
    outIntrinsics = intrinsics;
    outIntrinsics.width = w;
    outIntrinsics.height = h;
    outIntrinsics.fx /= factor;
    outIntrinsics.fy /= factor;
    outIntrinsics.cx /= factor;
    outIntrinsics.cy /= factor;
}

void RoomMemory::Impl::prepareDepth(const cv::Mat& depthMetres, const CameraIntrinsics& intrinsics) {
    subsampleInto(depthMetres, intrinsics, settings.processingWidth, subsampled, processed, processedIntrinsics);
}

std::optional<Pose> RoomMemory::Impl::trackFrom(const Pose& world_T_previous) {
    const DepthTrackingSettings& d = settings.depthTracking;
    subsampleInto(processed, processedIntrinsics, d.trackingWidth, trackingScratch, tracked, trackedIntrinsics);
    const CameraIntrinsics& k = trackedIntrinsics;
    if (!odometry || k.fx != odometryIntrinsics.fx || k.fy != odometryIntrinsics.fy || k.cx != odometryIntrinsics.cx ||
        k.cy != odometryIntrinsics.cy) {
        const cv::Mat cameraMatrix =
            (cv::Mat_<float>(3, 3) << float(k.fx), 0.f, float(k.cx), 0.f, float(k.fy), float(k.cy), 0.f, 0.f, 1.f);
        // Depth under 0.3 m is below any Kinect-class sensor's range; correspondences more than 7 cm apart in
        // depth are outliers (OpenCV's default); 4 pyramid levels with 7-7-7-10 iterations (its default).
        constexpr float kMinDepth = 0.3f, kMaxDepthDiff = 0.07f, kPointsPart = 0.07f;
        odometry = cv::rgbd::ICPOdometry::create(cameraMatrix, kMinDepth, float(settings.model.maxDepthMetres),
                                                 kMaxDepthDiff, kPointsPart);
        odometryIntrinsics = k;
    }
    const auto renderStart = Clock::now();
    model.renderDepthInto(world_T_previous, k, modelDepth, &modelNormals);
    stats.renderMs = msSince(renderStart);
    stats.constraintRatio = constraintRatioOf(modelDepth, modelNormals, k);
    if (stats.constraintRatio < d.minConstraintRatio) return std::nullopt;
    if (validFraction(tracked) < d.minValidFraction || validFraction(modelDepth) < d.minValidFraction)
        return std::nullopt;
    // Constant velocity: this frame is predicted to have moved from the previous one as the previous one did from
    // the one before. ICP then corrects a small residual instead of a whole frame's motion (8 cm per frame on
    // synth-orbit, more than its 7 cm correspondence gate).
    const Pose predicted = outputBefore ? outputBefore->inverse() * world_T_previous : Pose();
    toCv(predicted, initialRt);
    // Source: this frame; destination: the model seen from the previous pose. OpenCV's Rt maps source points to
    // destination points (dst_p = Rt * src_p), so Rt is previous_T_current.
    if (!odometry->compute(cv::Mat(), tracked, cv::Mat(), cv::Mat(), modelDepth, cv::Mat(), rt, initialRt))
        return std::nullopt;
    const Pose previous_T_current = poseFromCv(rt);
    const Pose correction = predicted.inverse() * previous_T_current;
    if (glm::length(correction.translation()) > d.maxCorrectionMetres ||
        Pose::rotationAngleBetween(correction, Pose()) > glm::radians(d.maxCorrectionDegrees))
        return std::nullopt;
    return world_T_previous * previous_T_current;
}

void RoomMemory::Impl::onTagFrame(tracking::TrackingResult& result) {
    const Pose tag = *result.world_T_camera;
    const DepthTrackingSettings& d = settings.depthTracking;
    if (sinceTagsFromDepth && !failed && lastOutput && d.enabled) {
        const auto t = Clock::now();
        if (const std::optional<Pose> depth = trackFrom(*lastOutput)) {
            blendOffset = tag.inverse() * *depth;
            blendLeft = d.blendFrames;
        }
        stats.trackMs = msSince(t);
    }
    sinceTagsFromDepth = false;
    depthRun = 0;
    expired = false;
    failed = false;
    const auto t = Clock::now();
    model.integrate(processed, processedIntrinsics, tag); // the tag pose, never the blended one
    stats.fuseMs = msSince(t);
    if (blendLeft > 0) {
        // s = 1 on the first tag frame (the output is that frame's depth pose), 1/blendFrames on the last.
        const double s = double(blendLeft) / double(d.blendFrames);
        result.world_T_camera = tag * fractionOf(blendOffset, s);
        --blendLeft;
    }
}

void RoomMemory::Impl::onNoTagFrame(tracking::TrackingResult& result) {
    const DepthTrackingSettings& d = settings.depthTracking;
    blendLeft = 0;
    expired = expired || depthRun >= d.maxFrames;
    if (expired) {
        // Drift without tags is unbounded: after maxFrames the pose is no longer trusted, nor the tag tracker's
        // older held one.
        result.state = tracking::TrackingState::Lost;
        result.world_T_camera.reset();
        result.reason = "depth tracking too long without tags";
        return;
    }
    if (!d.enabled || model.integratedFrames() == 0 || !lastOutput) return;
    // After a failure the last pose is stale (the camera moved on): ICP from it can settle in a wrong minimum
    // within the correction gate (24 degrees off on synth-pan), so the pose waits for the tags.
    if (!failed) {
        const auto t = Clock::now();
        const std::optional<Pose> depth = trackFrom(*lastOutput);
        stats.trackMs = msSince(t);
        failed = !depth;
        if (depth) {
            result.state = tracking::TrackingState::DepthTracked;
            result.world_T_camera = *depth;
            ++depthRun;
            sinceTagsFromDepth = true;
            return;
        }
    }
    if (sinceTagsFromDepth && result.state == tracking::TrackingState::Held) {
        // Held means the last pose repeated: ours, not the tag tracker's older one.
        result.world_T_camera = *lastOutput;
    }
}

void validate(const RoomMemorySettings& settings, const std::string& sourceName, const std::string& pointer) {
    validate(settings.model, sourceName, pointer);
    const DepthTrackingSettings& d = settings.depthTracking;
    const auto fail = [&](const std::string& key, const std::string& cause) {
        throw Error(sourceName, std::nullopt, pointer + "/" + key + ": " + cause);
    };
    // Written so that NaN fails too.
    if (settings.processingWidth < 16) fail("processingWidth", "expected an integer >= 16");
    if (d.trackingWidth < 16) fail("depthTracking/trackingWidth", "expected an integer >= 16");
    if (d.blendFrames < 1) fail("depthTracking/blendFrames", "expected an integer >= 1");
    if (d.maxFrames < 1) fail("depthTracking/maxFrames", "expected an integer >= 1");
    if (!(d.maxCorrectionMetres > 0.0 && d.maxCorrectionMetres <= 10.0))
        fail("depthTracking/maxCorrectionMetres", "expected a number in (0, 10]");
    if (!(d.maxCorrectionDegrees > 0.0 && d.maxCorrectionDegrees <= 180.0))
        fail("depthTracking/maxCorrectionDegrees", "expected a number in (0, 180]");
    if (!(d.minValidFraction >= 0.0 && d.minValidFraction <= 1.0))
        fail("depthTracking/minValidFraction", "expected a number in [0, 1]");
    if (!(d.minConstraintRatio >= 0.0 && d.minConstraintRatio <= 1.0))
        fail("depthTracking/minConstraintRatio", "expected a number in [0, 1]");
}

RoomMemory RoomMemory::create(const RoomMemorySettings& settings) {
    validate(settings, "room memory", "");
    auto impl = std::make_unique<Impl>(RoomModel::create(settings.model));
    impl->settings = settings;
    return RoomMemory(std::move(impl));
}

RoomMemory::RoomMemory(std::unique_ptr<Impl> impl)
    : impl_(std::move(impl)) {}
RoomMemory::RoomMemory(RoomMemory&&) noexcept = default;
RoomMemory& RoomMemory::operator=(RoomMemory&&) noexcept = default;
RoomMemory::~RoomMemory() = default;

void RoomMemory::update(const cv::Mat& depthMetres, const CameraIntrinsics& intrinsics,
                        tracking::TrackingResult& result) {
    Impl& m = *impl_;
    m.stats = {};
    if (depthMetres.empty()) return;
    LIGHTSKIN_ASSERT(depthMetres.type() == CV_32FC1 && depthMetres.cols == intrinsics.width &&
                         depthMetres.rows == intrinsics.height,
                     "expected CV_32FC1 metres of the intrinsics' size");
    m.prepareDepth(depthMetres, intrinsics);
    if (result.state == tracking::TrackingState::Tracking && result.world_T_camera)
        m.onTagFrame(result);
    else
        m.onNoTagFrame(result);
    m.outputBefore = m.lastOutput;
    m.lastOutput = result.world_T_camera;
    if (!m.lastOutput) {
        m.sinceTagsFromDepth = false;
        m.outputBefore.reset();
    }
}

void RoomMemory::reset() {
    impl_->model.reset();
    impl_->forgetPoses();
}

void RoomMemory::Impl::forgetPoses() {
    lastOutput.reset();
    outputBefore.reset();
    sinceTagsFromDepth = false;
    depthRun = 0;
    expired = false;
    failed = false;
    blendLeft = 0;
}

void RoomMemory::loadModel(const std::filesystem::path& file) {
    loadRoomModelInto(impl_->model, file); // throws before changing anything
    impl_->forgetPoses();
}

const RoomModel& RoomMemory::model() const noexcept { return impl_->model; }
const RoomMemorySettings& RoomMemory::settings() const noexcept { return impl_->settings; }
const RoomMemoryStats& RoomMemory::lastStats() const noexcept { return impl_->stats; }

} // namespace lightskin::roommodel
