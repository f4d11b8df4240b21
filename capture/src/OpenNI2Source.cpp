// OpenNI2 backend: live devices (PrimeSense, Asus Xtion, Orbbec; Kinect v1 only through
// libfreenect's OpenNI2 driver, which Debian does not package: use freenect:// instead) and
// .oni playback, both through the same pairing of depth and colour frames.
//
// .oni playback facts this code relies on (checked with Debian 12's OpenNI2 2.2.0.33 on
// tests/data/oni-kinect-v1): repeat is on by default (we switch it off); playback speed -1 steps
// manually so every frame arrives in order (speed 0 drops frames when the consumer is slow); the
// end of the file shows up only as a waitForAnyStream timeout; the colour stream may report a
// field of view of 0 (we fall back to the Kinect v1 default intrinsics); registration cannot be
// switched on during playback; the mirror flag may be set and cannot be cleared (we flip the
// images back so they match the pinhole intrinsics).
//
// Drivers: libOpenNI2 finds its drivers in OpenNI2/Drivers next to the library itself (Debian:
// /usr/lib/x86_64-linux-gnu/OpenNI2/Drivers), independent of the working directory.
#include "FramePairing.h"
#include "Sources.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/LeakCheck.h>
#include <lightskin/core/Log.h>

#include <OpenNI.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace lightskin::capture::detail {

namespace {

/// OpenNI::initialize/shutdown are process-global: reference-count them across sources.
///
/// OpenNI2's own log (no callback API: a console writer that printf()s onto stdout, or a file) goes to
/// a file in a private temporary folder, never the console (an OpenNI.ini may switch that on); its
/// warnings and errors are forwarded into our log at debug level with their source ("OpenNI2: ERROR
/// OniContext: Couldn't open device ..."; shown with -v) when a device fails to open and when the last
/// source closes: not per frame.
class OpenNIRuntime {
public:
    static void acquire(const std::string& uri) {
        std::lock_guard lock(mutex());
        if (count()++ == 0) {
            if (openni::OpenNI::initialize() != openni::STATUS_OK) {
                --count();
                throw Error(uri, std::nullopt,
                            std::string("OpenNI2 initialisation failed: ") + openni::OpenNI::getExtendedError());
            }
            routeLogToFile();
        }
        sanitizer::keepLoadedModulesMapped(); // OpenNI2/Drivers/*.so, for LeakSanitizer's report at exit
    }
    static void release() {
        std::lock_guard lock(mutex());
        forwardLogLocked();
        if (--count() == 0) {
            openni::OpenNI::shutdown();
            std::error_code ignored;
            if (!logFolder().empty()) std::filesystem::remove_all(logFolder(), ignored);
            logFolder().clear();
            logFile().clear();
        }
    }
    /// Forwards what OpenNI2 logged since the last call (see the class comment).
    static void forwardLog() {
        std::lock_guard lock(mutex());
        forwardLogLocked();
    }

private:
    static void routeLogToFile() {
        std::string pattern = (std::filesystem::temp_directory_path() / "lightskin-openni2-XXXXXX").string();
        if (::mkdtemp(pattern.data()) == nullptr) { // no log then, but never the console
            openni::OpenNI::setLogConsoleOutput(false);
            return;
        }
        logFolder() = pattern;
        openni::OpenNI::setLogConsoleOutput(false);
        openni::OpenNI::setLogOutputFolder(pattern.c_str());
        openni::OpenNI::setLogMinSeverity(2); // 0 verbose, 1 info, 2 warning, 3 error
        openni::OpenNI::setLogFileOutput(true);
        char name[4096] = {};
        if (openni::OpenNI::getLogFileName(name, sizeof name) == openni::STATUS_OK) logFile() = name;
        logOffset() = 0;
    }
    static void forwardLogLocked() {
        if (logFile().empty()) return;
        std::ifstream file(logFile(), std::ios::binary);
        file.seekg(static_cast<std::streamoff>(logOffset()));
        std::string line;
        while (std::getline(file, line)) {
            if (file.eof()) break; // an unfinished last line: read it once it is complete
            logOffset() += line.size() + 1;
            // "<time>\t<SEVERITY>\t<mask>\t<file>\t<line>\t<message>" (XnLog's file format)
            std::vector<std::string> fields;
            std::istringstream parts(line);
            for (std::string field; std::getline(parts, field, '\t');) fields.push_back(field);
            if (fields.size() < 6) continue;
            const auto trim = [](std::string text) {
                while (!text.empty() && (text.back() == ' ' || text.back() == '\r')) text.pop_back();
                return text;
            };
            const std::string severity = trim(fields[1]);
            if (severity == "VERBOSE" || severity == "INFO") continue; // the log's own header lines
            std::string message = trim(fields[5]);
            for (std::size_t i = 6; i < fields.size(); ++i) message += " " + trim(fields[i]);
            log::debug("OpenNI2: " + severity + " " + trim(fields[2]) + ": " + message);
        }
    }
    static std::filesystem::path& logFolder() {
        static std::filesystem::path folder;
        return folder;
    }
    static std::string& logFile() {
        static std::string name;
        return name;
    }
    static std::size_t& logOffset() {
        static std::size_t offset = 0;
        return offset;
    }
    static std::mutex& mutex() {
        static std::mutex m;
        return m;
    }
    static int& count() {
        static int c = 0;
        return c;
    }
};

struct RuntimeReference {
    explicit RuntimeReference(const std::string& uri) { OpenNIRuntime::acquire(uri); }
    ~RuntimeReference() { OpenNIRuntime::release(); }
    RuntimeReference(const RuntimeReference&) = delete;
    RuntimeReference& operator=(const RuntimeReference&) = delete;
};

CameraIntrinsics intrinsicsFromFieldOfView(int width, int height, float horizontal, float vertical) {
    CameraIntrinsics k;
    k.width = width;
    k.height = height;
    k.fx = (width / 2.0) / std::tan(double(horizontal) / 2.0);
    k.fy = (height / 2.0) / std::tan(double(vertical) / 2.0);
    k.cx = width / 2.0 - 0.5;
    k.cy = height / 2.0 - 0.5;
    return k;
}

double depthScaleOf(openni::PixelFormat format) {
    switch (format) {
    case openni::PIXEL_FORMAT_DEPTH_1_MM:
        return 0.001;
    case openni::PIXEL_FORMAT_DEPTH_100_UM:
        return 0.0001;
    default:
        return 0.0;
    }
}

class OpenNI2Source final : public FrameSource {
public:
    OpenNI2Source(FrameSourceInfo info, FrameSourceOptions options)
        : FrameSource(std::move(info), std::move(options)) {}

    ~OpenNI2Source() override { close(); }

    void close() {
        for (openni::VideoStream* stream : {&depth_, &colour_})
            if (stream->isValid()) stream->stop();
        // Debian's OniFile driver (OpenNI2 2.2) walks its stream list from the player thread
        // without a lock, continuously while any stream is started (and spinning at end of file).
        // Destroying a stream during that walk is a use-after-free: the .oni test segfaulted in
        // about 1 run in 15. Once every stream is stopped the thread only looks at the list every
        // 10 ms, so give it ten times that (the machine may be loaded) to park before the streams go away.
        if (playback_ != nullptr) std::this_thread::sleep_for(std::chrono::milliseconds(100));
        for (openni::VideoStream* stream : {&depth_, &colour_})
            if (stream->isValid()) stream->destroy();
        if (device_.isValid()) device_.close();
        playback_ = nullptr;
    }

    void open(bool file) {
        const std::string& uri = info_.uri;
        file_ = file;
        if (device_.open(file ? uri.c_str() : (uri.empty() ? openni::ANY_DEVICE : uri.c_str())) != openni::STATUS_OK) {
            // OpenNI2's text is "\tDeviceOpen: Couldn't open device '...'\n\n": one line, no tabs.
            std::string detail = openni::OpenNI::getExtendedError();
            for (char& c : detail)
                if (c == '\t' || c == '\n' || c == '\r') c = ' ';
            detail.erase(0, detail.find_first_not_of(' '));
            detail.erase(detail.find_last_not_of(' ') + 1);
            OpenNIRuntime::forwardLog();
            throw Error(file ? uri : "openni2://" + uri, std::nullopt,
                        std::string(file ? "OpenNI2 cannot open the file (truncated, header only or not an .oni?)"
                                         : "OpenNI2 cannot open the device (not connected, no driver, or in use?)") +
                            (detail.empty() ? "" : ": " + detail));
        }
        info_.deviceName = device_.getDeviceInfo().getName();
        if (!file) info_.deviceName = std::string(device_.getDeviceInfo().getVendor()) + " " + info_.deviceName;
        if (file) {
            playback_ = device_.getPlaybackControl();
            if (!playback_) throw Error(uri, std::nullopt, "file opened but OpenNI2 offers no playback control");
            playback_->setRepeatEnabled(false);
            playback_->setSpeed(-1.0f); // manual stepping: every frame, in order
        }
        if (!device_.hasSensor(openni::SENSOR_DEPTH) ||
            depth_.create(device_, openni::SENSOR_DEPTH) != openni::STATUS_OK)
            throw Error(uri, std::nullopt, std::string("no depth stream: ") + openni::OpenNI::getExtendedError());
        if (device_.hasSensor(openni::SENSOR_COLOR) &&
            colour_.create(device_, openni::SENSOR_COLOR) != openni::STATUS_OK)
            throw Error(uri, std::nullopt,
                        std::string("cannot create the colour stream: ") + openni::OpenNI::getExtendedError());
        if (!file) configureLive();

        for (openni::VideoStream* stream : {&depth_, &colour_}) {
            if (!stream->isValid()) continue;
            // Mirroring: prefer turning it off; where the stream refuses (files), flip ourselves.
            if (stream->getMirroringEnabled()) stream->setMirroringEnabled(false);
            (stream == &depth_ ? flipDepth_ : flipColour_) = stream->getMirroringEnabled();
        }
        const openni::VideoMode depthMode = depth_.getVideoMode();
        info_.depthScaleMetres = depthScaleOf(depthMode.getPixelFormat());
        if (info_.depthScaleMetres == 0.0)
            throw Error(uri, std::nullopt,
                        "depth pixel format " + std::to_string(int(depthMode.getPixelFormat())) +
                            " is not metric (1 mm or 100 um)");
        const int depthWidth = depthMode.getResolutionX(), depthHeight = depthMode.getResolutionY();
        depthWidth_ = depthWidth;
        depthHeight_ = depthHeight;
        if (depthWidth <= 0 || depthHeight <= 0 || depthWidth > 16384 || depthHeight > 16384)
            throw Error(uri, std::nullopt,
                        "absurd depth resolution " + std::to_string(depthWidth) + "x" + std::to_string(depthHeight));
        info_.depthIntrinsics = intrinsicsFromFieldOfView(depthWidth, depthHeight, depth_.getHorizontalFieldOfView(),
                                                          depth_.getVerticalFieldOfView());
        if (!info_.depthIntrinsics.isValid() || !(depth_.getHorizontalFieldOfView() > 0.0f))
            info_.depthIntrinsics = CameraIntrinsics::kinectV1Default().scaledTo(depthWidth, depthHeight);
        if (colour_.isValid()) {
            const openni::VideoMode colourMode = colour_.getVideoMode();
            const int w = colourMode.getResolutionX(), h = colourMode.getResolutionY();
            if (w <= 0 || h <= 0 || w > 16384 || h > 16384)
                throw Error(uri, std::nullopt,
                            "absurd colour resolution " + std::to_string(w) + "x" + std::to_string(h));
            const float hfov = colour_.getHorizontalFieldOfView(), vfov = colour_.getVerticalFieldOfView();
            if (hfov > 0.0f && vfov > 0.0f)
                info_.colourIntrinsics = intrinsicsFromFieldOfView(w, h, hfov, vfov);
            else {
                // The file holds no colour field of view: Kinect v1 / PrimeSense default (ROS 525).
                info_.colourIntrinsics = CameraIntrinsics::kinectV1Default().scaledTo(w, h);
                log::info(uri + ": colour field of view is 0, using the default intrinsics " +
                          info_.colourIntrinsics.describe());
            }
            colourFormat_ = colourMode.getPixelFormat();
            if (colourFormat_ != openni::PIXEL_FORMAT_RGB888 && colourFormat_ != openni::PIXEL_FORMAT_YUV422 &&
                colourFormat_ != openni::PIXEL_FORMAT_YUYV && colourFormat_ != openni::PIXEL_FORMAT_GRAY8)
                throw Error(uri, std::nullopt,
                            "colour pixel format " + std::to_string(int(colourFormat_)) + " is not supported");
        }
        registered_ = device_.getImageRegistrationMode() == openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR;
        info_.registration = registered_ ? DepthRegistration::RegisteredToColour : DepthRegistration::Unregistered;
        if (registered_) info_.depthIntrinsics = info_.colourIntrinsics;
        if (options_.intrinsics) info_.colourIntrinsics = info_.depthIntrinsics = *options_.intrinsics;
        // OpenNI2 reports no depth-to-colour extrinsic. Unregistered PrimeSense/Kinect v1 depth:
        // the published Kinect v1 baseline (Registration.h) for software registration.
        if (!registered_) info_.colour_T_depth = kinectV1DefaultColour_T_depth();
        info_.calibrationSource =
            std::string(options_.intrinsics ? "intrinsics given by the caller" : "depth: the stream's field of view") +
            (colour_.isValid() && !options_.intrinsics && !(colour_.getHorizontalFieldOfView() > 0.0f)
                 ? "; colour: Kinect v1 default 525/525/319.5/239.5 (ROS)"
                 : "") +
            (registered_ ? "; registered by the device"
                         : "; colour_T_depth: Kinect v1 default, 2.5 cm baseline (NYU Depth V2 toolbox)");
        if (registered_ && colour_.isValid() &&
            (info_.colourIntrinsics.width != depthWidth || info_.colourIntrinsics.height != depthHeight))
            throw Error(uri, std::nullopt, "registered depth and colour have different sizes");
        if (file) {
            depthFrames_ = playback_->getNumberOfFrames(depth_);
            colourFrames_ = colour_.isValid() ? playback_->getNumberOfFrames(colour_) : depthFrames_;
            if (depthFrames_ <= 0) throw Error(uri, std::nullopt, "the file holds no depth frames");
        }
        if (depth_.start() != openni::STATUS_OK)
            throw Error(uri, std::nullopt,
                        std::string("cannot start the depth stream: ") + openni::OpenNI::getExtendedError());
        if (colour_.isValid() && colour_.start() != openni::STATUS_OK)
            throw Error(uri, std::nullopt,
                        std::string("cannot start the colour stream: ") + openni::OpenNI::getExtendedError());
    }

    std::optional<std::int64_t> frameCount() const override {
        if (!file_) return std::nullopt;
        return std::int64_t(std::min(depthFrames_, colourFrames_));
    }
    bool canSeek() const noexcept override { return file_; }

protected:
    bool readNext(RgbdFrame& out) override {
        if (file_ && next_ >= *frameCount()) return false;
        const auto timeout = file_ ? options_.oniEndOfFileTimeout : options_.liveTimeout;
        haveDepth_ = haveColour_ = false;
        openni::VideoStream* streams[] = {&depth_, &colour_};
        const int streamCount = colour_.isValid() ? 2 : 1;
        while (!haveDepth_ || (streamCount == 2 && !haveColour_)) {
            int ready = -1;
            const openni::Status status =
                openni::OpenNI::waitForAnyStream(streams, streamCount, &ready, int(timeout.count()));
            if (status == openni::STATUS_TIME_OUT) {
                if (file_) {
                    // End of file: an unpaired last frame cannot be delivered.
                    if (haveDepth_ || haveColour_) ++unpaired_;
                    parkPlayer();
                    return false;
                }
                throw SourceStalled("openni2://" + info_.uri, next_,
                                    "no frame for " + std::to_string(timeout.count()) +
                                        " ms: device stalled or unplugged");
            }
            if (status != openni::STATUS_OK || ready < 0)
                throw Error(info_.uri, next_,
                            std::string("waiting for frames failed: ") + openni::OpenNI::getExtendedError());
            openni::VideoFrameRef frame;
            if (streams[ready]->readFrame(&frame) != openni::STATUS_OK)
                throw Error(info_.uri, next_,
                            std::string("reading a frame failed: ") + openni::OpenNI::getExtendedError());
            if (ready == 0) {
                if (haveDepth_) ++unpaired_; // a second depth before its colour: the older one is lost
                takeDepth(frame, out);
            } else {
                if (haveColour_) ++unpaired_;
                takeColour(frame, out);
            }
            // .oni: a frame whose partner OpenNI2's player skipped is dropped (FramePairing.h).
            if (file_ && haveDepth_ && haveColour_) {
                const auto decision = pairing_.decide(heldDepthIndex_, heldColourIndex_);
                if (decision != FrameIndexPairing::Decision::Pair) ++unpaired_;
                if (decision == FrameIndexPairing::Decision::DropDepth) haveDepth_ = false;
                if (decision == FrameIndexPairing::Decision::DropColour) haveColour_ = false;
            }
        }
        if (colour_.isValid() == false) out.colour.release();
        stampFrame(out, next_++);
        if (file_ && next_ >= *frameCount()) parkPlayer();
        return true;
    }

    void seekTo(std::int64_t index) override {
        // PlaybackControl::seek crashes Debian's OniFile driver (2.2.0.33) in the middle of a file
        // (segmentation fault, checked on tests/data/oni-kinect-v1): reopen the file and step
        // forward instead, which costs decoding `index` frames.
        close();
        open(true);
        next_ = 0;
        lastDepthIndex_ = lastColourIndex_ = -1;
        pairing_.reset();
        while (next_ < index)
            if (!readNext(seekScratch_)) throw Error(info_.uri, index, "seek beyond the end of the file");
    }

    std::int64_t deviceDropped() const noexcept override { return gaps_ + unpaired_; }

private:
    /// At the file's end: Debian's OniFile player thread reads on in a loop that returns at once at the end of a
    /// file without repeat, a core busy until the source closes, while any stream is started. Stopped streams park
    /// it (it then looks every 10 ms). seekTo() reopens the file.
    void parkPlayer() {
        for (openni::VideoStream* stream : {&depth_, &colour_})
            if (stream->isValid()) stream->stop();
    }

    void configureLive() {
        // Ask for VGA 30 fps depth in millimetres and RGB888 colour when the device offers them.
        const auto choose = [](openni::VideoStream& stream, openni::PixelFormat format) {
            const auto& modes = stream.getSensorInfo().getSupportedVideoModes();
            for (int i = 0; i < modes.getSize(); ++i)
                if (modes[i].getPixelFormat() == format && modes[i].getResolutionX() == 640 &&
                    modes[i].getResolutionY() == 480 && modes[i].getFps() == 30) {
                    stream.setVideoMode(modes[i]);
                    return;
                }
        };
        choose(depth_, openni::PIXEL_FORMAT_DEPTH_1_MM);
        if (colour_.isValid()) choose(colour_, openni::PIXEL_FORMAT_RGB888);
        if (colour_.isValid()) device_.setDepthColorSyncEnabled(true);
        if (options_.registerDepth && colour_.isValid()) {
            if (device_.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR))
                device_.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR);
            else
                log::warning("openni2://" + info_.uri + ": the device cannot register depth to colour");
        }
    }

    void countGap(int frameIndex, int& last) {
        if (last >= 0 && frameIndex > last + 1) gaps_ += frameIndex - last - 1;
        last = frameIndex;
    }

    void takeDepth(const openni::VideoFrameRef& frame, RgbdFrame& out) {
        const int w = frame.getWidth(), h = frame.getHeight();
        if (w != depthWidth_ || h != depthHeight_ || frame.getDataSize() < w * h * 2 ||
            frame.getStrideInBytes() < w * 2)
            throw Error(info_.uri, next_,
                        "depth frame size " + std::to_string(w) + "x" + std::to_string(h) +
                            " does not match the stream");
        const cv::Mat view(h, w, CV_16UC1, const_cast<void*>(frame.getData()), std::size_t(frame.getStrideInBytes()));
        out.depth.create(h, w, CV_16UC1);
        if (flipDepth_)
            cv::flip(view, out.depth, 1);
        else
            view.copyTo(out.depth);
        out.depthTimestampSeconds = double(frame.getTimestamp()) * 1e-6;
        countGap(frame.getFrameIndex(), lastDepthIndex_);
        heldDepthIndex_ = frame.getFrameIndex();
        haveDepth_ = true;
    }

    void takeColour(const openni::VideoFrameRef& frame, RgbdFrame& out) {
        const int w = frame.getWidth(), h = frame.getHeight();
        const int bytesPerPixel = colourFormat_ == openni::PIXEL_FORMAT_RGB888  ? 3
                                  : colourFormat_ == openni::PIXEL_FORMAT_GRAY8 ? 1
                                                                                : 2;
        if (w != info_.colourIntrinsics.width || h != info_.colourIntrinsics.height ||
            frame.getDataSize() < w * h * bytesPerPixel || frame.getStrideInBytes() < w * bytesPerPixel)
            throw Error(info_.uri, next_,
                        "colour frame size " + std::to_string(w) + "x" + std::to_string(h) +
                            " does not match the stream");
        void* data = const_cast<void*>(frame.getData());
        const std::size_t stride = std::size_t(frame.getStrideInBytes());
        out.colour.create(h, w, CV_8UC3);
        switch (colourFormat_) {
        case openni::PIXEL_FORMAT_RGB888:
            cv::cvtColor(cv::Mat(h, w, CV_8UC3, data, stride), out.colour, cv::COLOR_RGB2BGR);
            break;
        case openni::PIXEL_FORMAT_YUV422:
            cv::cvtColor(cv::Mat(h, w, CV_8UC2, data, stride), out.colour, cv::COLOR_YUV2BGR_UYVY);
            break;
        case openni::PIXEL_FORMAT_YUYV:
            cv::cvtColor(cv::Mat(h, w, CV_8UC2, data, stride), out.colour, cv::COLOR_YUV2BGR_YUYV);
            break;
        default:
            cv::cvtColor(cv::Mat(h, w, CV_8UC1, data, stride), out.colour, cv::COLOR_GRAY2BGR);
            break;
        }
        if (flipColour_) cv::flip(out.colour, out.colour, 1);
        out.colourTimestampSeconds = double(frame.getTimestamp()) * 1e-6;
        countGap(frame.getFrameIndex(), lastColourIndex_);
        heldColourIndex_ = frame.getFrameIndex();
        haveColour_ = true;
    }

    RuntimeReference runtime_{info_.uri};
    openni::Device device_;
    openni::VideoStream depth_, colour_;
    openni::PlaybackControl* playback_ = nullptr;
    RgbdFrame seekScratch_;
    openni::PixelFormat colourFormat_ = openni::PIXEL_FORMAT_RGB888;
    bool file_ = false, registered_ = false, flipDepth_ = false, flipColour_ = false;
    bool haveDepth_ = false, haveColour_ = false;
    int depthFrames_ = 0, colourFrames_ = 0;
    int depthWidth_ = 0, depthHeight_ = 0; // the stream's own size (info_ may describe registered frames)
    int lastDepthIndex_ = -1, lastColourIndex_ = -1;
    int heldDepthIndex_ = 0, heldColourIndex_ = 0; // OpenNI2's numbers of the frames in `out`
    FrameIndexPairing pairing_;
    std::int64_t next_ = 0, gaps_ = 0, unpaired_ = 0;
};

} // namespace

std::unique_ptr<FrameSource> openOpenNI2Source(const std::string& uri, bool file, const FrameSourceOptions& options) {
    FrameSourceInfo info;
    info.kind = file ? "oni" : "openni2";
    info.uri = uri;
    info.live = !file;
    if (file) {
        std::error_code error;
        const auto size = std::filesystem::file_size(uri, error);
        if (error) throw Error(uri, std::nullopt, "cannot read the file: " + error.message());
        // OpenNI's own header is 40+ bytes; a file without any frame data cannot be played.
        if (size < 1024)
            throw Error(uri, std::nullopt, "file is only " + std::to_string(size) + " bytes: no frames in it");
    }
    auto source = std::make_unique<OpenNI2Source>(std::move(info), options);
    source->open(file);
    return source;
}

} // namespace lightskin::capture::detail
