// libfreenect backend: a live Kinect v1 with depth registered to colour in millimetres
// (FREENECT_DEPTH_REGISTERED) and RGB colour, 640x480. Tested without hardware through Debian's
// fakenect, which replaces libfreenect.so at run time (see Fakenect.h).
//
// libfreenect delivers depth and video through callbacks from freenect_process_events(); we pump
// events until one new frame of each stream has arrived and pair them. Timestamps are the host's
// steady clock when each callback ran (the device's 32-bit counters are not in seconds).
#include "Sources.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>

#include <libfreenect.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <array>
#include <chrono>
#include <cmath>
#include <sys/time.h>

namespace lightskin::capture::detail {

namespace {

inline constexpr int kWidth = 640, kHeight = 480;

}

std::uint16_t millimetresFromDisparity(int disparity) {
    // Kinect v1 raw disparity to depth, a widely used calibration (../shared/FACTS.md):
    // z[m] = 1 / (-0.0030711016 d + 3.3309495161). 2047 = no measurement; beyond 10 m invalid.
    if (disparity < 0 || disparity >= 2047) return 0;
    const double denominator = -0.0030711016 * disparity + 3.3309495161;
    if (denominator <= 0.1) return 0;
    return static_cast<std::uint16_t>(std::lround(1000.0 / denominator));
}

int disparityFromMillimetres(std::uint16_t millimetres) {
    if (millimetres == 0) return 2047;
    const double disparity = (1000.0 / millimetres - 3.3309495161) / -0.0030711016;
    const long rounded = std::lround(disparity);
    if (rounded < 0 || rounded >= 2047 || millimetresFromDisparity(int(rounded)) == 0) return 2047;
    return int(rounded);
}

namespace {

class FreenectSource final : public FrameSource {
public:
    FreenectSource(FrameSourceInfo info, FrameSourceOptions options)
        : FrameSource(std::move(info), std::move(options))
        , depthBuffer_(kHeight, kWidth, CV_16UC1)
        , videoBuffer_(kHeight, kWidth, CV_8UC3) {}

    ~FreenectSource() override {
        if (device_) {
            if (depthStarted_) freenect_stop_depth(device_);
            if (videoStarted_) freenect_stop_video(device_);
            freenect_close_device(device_);
        }
        if (context_) freenect_shutdown(context_);
    }

    void open(int deviceIndex) {
        const std::string& uri = info_.uri;
        if (freenect_init(&context_, nullptr) < 0 || !context_) {
            context_ = nullptr;
            throw Error(uri, std::nullopt, "libfreenect initialisation failed");
        }
        freenect_set_log_level(context_, FREENECT_LOG_ERROR);
        freenect_select_subdevices(context_, FREENECT_DEVICE_CAMERA);
        const int devices = freenect_num_devices(context_);
        if (deviceIndex >= devices)
            throw Error(uri, std::nullopt,
                        "no Kinect v1 with index " + std::to_string(deviceIndex) + " (" + std::to_string(devices) +
                            " found)");
        if (freenect_open_device(context_, &device_, deviceIndex) < 0 || !device_) {
            device_ = nullptr;
            throw Error(uri, std::nullopt, "cannot open the Kinect (permissions? another program using it?)");
        }
        freenect_set_user(device_, this);
        // Modes by enumeration (freenect_find_*_mode asserts on modes Debian's fakenect lacks).
        const freenect_depth_format wanted = options_.registerDepth ? FREENECT_DEPTH_REGISTERED : FREENECT_DEPTH_MM;
        std::optional<freenect_frame_mode> depthMode, rawMode, videoMode;
        for (int i = 0; i < freenect_get_depth_mode_count(); ++i) {
            const freenect_frame_mode mode = freenect_get_depth_mode(i);
            if (!mode.is_valid || mode.resolution != FREENECT_RESOLUTION_MEDIUM) continue;
            if (mode.depth_format == wanted) depthMode = mode;
            if (mode.depth_format == FREENECT_DEPTH_11BIT) rawMode = mode;
        }
        for (int i = 0; i < freenect_get_video_mode_count(); ++i) {
            const freenect_frame_mode mode = freenect_get_video_mode(i);
            if (mode.is_valid && mode.resolution == FREENECT_RESOLUTION_MEDIUM &&
                mode.video_format == FREENECT_VIDEO_RGB)
                videoMode = mode;
        }
        // Without a metric mode (old libfreenect, Debian's fakenect 0.5.3) take raw 11-bit
        // disparity and convert it ourselves: unregistered depth in the IR camera.
        rawDisparity_ = !depthMode.has_value();
        if (rawDisparity_) depthMode = rawMode;
        if (!depthMode || !videoMode || depthMode->width != kWidth || depthMode->height != kHeight ||
            videoMode->width != kWidth || videoMode->height != kHeight)
            throw Error(uri, std::nullopt, "libfreenect offers no 640x480 depth and RGB modes");
        if (freenect_set_depth_mode(device_, *depthMode) < 0 || freenect_set_video_mode(device_, *videoMode) < 0)
            throw Error(uri, std::nullopt, "cannot set the depth and video modes");
        if (rawDisparity_) {
            log::info(uri +
                      ": libfreenect offers no registered depth mode: converting raw 11-bit disparity (unregistered)");
            for (int d = 0; d < 2048; ++d) disparityToMillimetres_[std::size_t(d)] = millimetresFromDisparity(d);
        }
        freenect_set_depth_buffer(device_, depthBuffer_.data);
        freenect_set_video_buffer(device_, videoBuffer_.data);
        freenect_set_depth_callback(device_, &FreenectSource::depthCallback);
        freenect_set_video_callback(device_, &FreenectSource::videoCallback);
        if (freenect_start_depth(device_) < 0) throw Error(uri, std::nullopt, "cannot start the depth stream");
        depthStarted_ = true;
        if (freenect_start_video(device_) < 0) throw Error(uri, std::nullopt, "cannot start the video stream");
        videoStarted_ = true;

        info_.deviceName = "Kinect v1 (libfreenect)";
        info_.depthScaleMetres = 0.001;
        // libfreenect registers depth into the RGB camera: the Kinect v1 default colour intrinsics.
        info_.colourIntrinsics = options_.intrinsics.value_or(CameraIntrinsics::kinectV1Default());
        const bool registered = options_.registerDepth && !rawDisparity_;
        info_.registration = registered ? DepthRegistration::RegisteredToColour : DepthRegistration::Unregistered;
        // Unregistered: the IR camera (ROS openni_camera's default depth focal length 575.8 px) and
        // the published Kinect v1 baseline (Registration.h): libfreenect's per-device registration
        // tables are not a pinhole model, so software registration uses these defaults.
        info_.depthIntrinsics =
            registered ? info_.colourIntrinsics : options_.intrinsics.value_or(kinectV1DefaultDepthIntrinsics());
        if (!registered) info_.colour_T_depth = kinectV1DefaultColour_T_depth();
        info_.calibrationSource = registered
                                      ? "registered by libfreenect"
                                      : "Kinect v1 defaults: depth f 575.8 (ROS openni_camera), colour 525 (ROS), "
                                        "colour_T_depth 2.5 cm baseline (NYU Depth V2 toolbox)";
        start_ = std::chrono::steady_clock::now();
    }

protected:
    bool readNext(RgbdFrame& out) override {
        target_ = &out;
        haveDepth_ = haveVideo_ = false;
        const auto deadline = std::chrono::steady_clock::now() + options_.liveTimeout;
        while (!haveDepth_ || !haveVideo_) {
            timeval timeout{0, 100000};
            if (freenect_process_events_timeout(context_, &timeout) < 0) {
                // A real device reports errors here; fakenect reports the end of its dump.
                log::info(info_.uri +
                          ": libfreenect stopped delivering events (end of a fakenect dump or device lost)");
                if (haveDepth_ || haveVideo_) ++unpaired_;
                target_ = nullptr;
                return false;
            }
            if (std::chrono::steady_clock::now() > deadline) {
                target_ = nullptr;
                throw SourceStalled(info_.uri, next_,
                                    "no frame pair for " + std::to_string(options_.liveTimeout.count()) +
                                        " ms: Kinect stalled or unplugged");
            }
        }
        target_ = nullptr;
        stampFrame(out, next_++);
        return true;
    }

    std::int64_t deviceDropped() const noexcept override { return unpaired_; }

private:
    double now() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

    static void depthCallback(freenect_device* device, void* data, std::uint32_t) {
        auto* self = static_cast<FreenectSource*>(freenect_get_user(device));
        if (!self || !self->target_) return; // between next() calls: the frame is not wanted
        if (self->haveDepth_) ++self->unpaired_;
        const cv::Mat view(kHeight, kWidth, CV_16UC1, data);
        if (self->rawDisparity_) {
            cv::Mat& depth = self->target_->depth;
            depth.create(kHeight, kWidth, CV_16UC1);
            const auto* raw = view.ptr<std::uint16_t>();
            auto* millimetres = depth.ptr<std::uint16_t>();
            for (int i = 0; i < kWidth * kHeight; ++i) millimetres[i] = self->disparityToMillimetres_[raw[i] & 2047u];
        } else {
            view.copyTo(self->target_->depth);
        }
        self->target_->depthTimestampSeconds = self->now();
        self->haveDepth_ = true;
    }

    static void videoCallback(freenect_device* device, void* data, std::uint32_t) {
        auto* self = static_cast<FreenectSource*>(freenect_get_user(device));
        if (!self || !self->target_) return;
        if (self->haveVideo_) ++self->unpaired_;
        cv::cvtColor(cv::Mat(kHeight, kWidth, CV_8UC3, data), self->target_->colour, cv::COLOR_RGB2BGR);
        self->target_->colourTimestampSeconds = self->now();
        self->haveVideo_ = true;
    }

    bool rawDisparity_ = false;
    std::array<std::uint16_t, 2048> disparityToMillimetres_{};
    freenect_context* context_ = nullptr;
    freenect_device* device_ = nullptr;
    bool depthStarted_ = false, videoStarted_ = false;
    cv::Mat depthBuffer_, videoBuffer_;
    RgbdFrame* target_ = nullptr;
    bool haveDepth_ = false, haveVideo_ = false;
    std::int64_t next_ = 0, unpaired_ = 0;
    std::chrono::steady_clock::time_point start_;
};

} // namespace

std::unique_ptr<FrameSource> openFreenectSource(int deviceIndex, const FrameSourceOptions& options) {
    FrameSourceInfo info;
    info.kind = "freenect";
    info.uri = "freenect://" + std::to_string(deviceIndex);
    info.live = true;
    auto source = std::make_unique<FreenectSource>(std::move(info), options);
    source->open(deviceIndex);
    return source;
}

} // namespace lightskin::capture::detail
