#include "Sources.h"

#include <lightskin/capture/FrameSource.h>
#include <lightskin/capture/Recording.h>
#include <lightskin/core/Error.h>

#include <cmath>
#include <thread>

namespace lightskin::capture {

FrameSource::FrameSource(FrameSourceInfo info, FrameSourceOptions options)
    : info_(std::move(info))
    , options_(std::move(options)) {}

FrameSource::~FrameSource() = default;

bool FrameSource::skipNext() { return readNext(skipScratch_); }

void FrameSource::seekTo(std::int64_t) { throw Error(info_.uri, std::nullopt, "this source cannot seek"); }

void FrameSource::seek(std::int64_t index) {
    if (!canSeek()) throw Error(info_.uri, index, "this source cannot seek (" + info_.kind + ")");
    const auto count = frameCount();
    if (index < 0 || (count && index >= *count))
        throw Error(info_.uri, index, "seek outside the source (" + std::to_string(count.value_or(0)) + " frames)");
    seekTo(index);
    paceStarted_ = false;
}

bool FrameSource::next(RgbdFrame& out) {
    const bool pace = options_.pacing == Pacing::Realtime && !info_.live;
    const auto elapsedSeconds = [&] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - paceStart_).count();
    };
    bool restarted = false;
    for (;;) {
        if (pace && paceStarted_) {
            if (const auto due = peekNextTimestamp(); due && std::isfinite(*due)) {
                const double late = elapsedSeconds() - (*due - paceFirstTimestamp_);
                if (late > options_.realtimeLateToleranceSeconds && skipNext()) {
                    ++dropped_;
                    continue;
                }
            }
        }
        // Software registration: readNext() fills the raw buffer, registerInto() the handed-out one.
        if (registrar_) out.depth = rawDepth_;
        if (!readNext(out)) {
            // Loop: start again at frame 0, once per call (an empty source must not spin).
            if (options_.loop && canSeek() && !restarted && frameCount().value_or(0) > 0) {
                restarted = true;
                seekTo(0);
                paceStarted_ = false;
                continue;
            }
            return false;
        }
        break;
    }
    if (pace) {
        const double time =
            std::isfinite(out.depthTimestampSeconds) ? out.depthTimestampSeconds : out.colourTimestampSeconds;
        if (std::isfinite(time)) {
            if (!paceStarted_) {
                paceStarted_ = true;
                paceFirstTimestamp_ = time;
                paceStart_ = std::chrono::steady_clock::now();
            } else {
                const double wait = (time - paceFirstTimestamp_) - elapsedSeconds();
                if (wait > 0.0) std::this_thread::sleep_for(std::chrono::duration<double>(wait));
            }
        }
    }
    if (registrar_ && !out.depth.empty()) {
        rawDepth_ = out.depth;
        const auto& raw = *info_.softwareRegistration;
        if (rawDepth_.type() != CV_16UC1 || rawDepth_.cols != raw.depth.width || rawDepth_.rows != raw.depth.height)
            throw Error(info_.uri, out.index,
                        "depth frame " + std::to_string(rawDepth_.cols) + "x" + std::to_string(rawDepth_.rows) +
                            " does not match the depth camera's calibration (" + raw.depth.describe() + ")");
        registrar_->registerInto(rawDepth_, out.depthScaleMetres, registeredDepth_);
        out.depth = registeredDepth_;
    }
    ++delivered_;
    return true;
}

void FrameSource::enableSoftwareRegistration() {
    if (!options_.softwareRegistration || info_.registration != DepthRegistration::Unregistered) return;
    if (!info_.colourIntrinsics.isValid()) return; // no colour camera to register into
    RegistrationCalibration calibration;
    calibration.depth = info_.depthIntrinsics;
    calibration.colour = info_.colourIntrinsics;
    calibration.colour_T_depth = info_.colour_T_depth;
    calibration.source = info_.uri + (info_.calibrationSource.empty() ? "" : " (" + info_.calibrationSource + ")");
    registrar_ = DepthRegistrar::create(calibration);
    info_.softwareRegistration = calibration;
    info_.registration = DepthRegistration::RegisteredToColour;
    info_.depthIntrinsics = info_.colourIntrinsics;
    info_.colour_T_depth = Pose();
}

namespace {

std::unique_ptr<FrameSource> openUnregistered(const std::string& uriOrPath, const FrameSourceOptions& options) {
    if (uriOrPath.rfind("openni2://", 0) == 0) return detail::openOpenNI2Source(uriOrPath.substr(10), false, options);
    if (uriOrPath.rfind("freenect://", 0) == 0) {
        const std::string rest = uriOrPath.substr(11);
        int index = 0;
        if (!rest.empty()) {
            std::size_t used = 0;
            try {
                index = std::stoi(rest, &used);
            } catch (const std::exception&) {
                used = 0;
            }
            if (used != rest.size() || index < 0)
                throw Error(uriOrPath, std::nullopt, "expected freenect://<device index>");
        }
        return detail::openFreenectSource(index, options);
    }
    const std::filesystem::path path(uriOrPath);
    std::error_code error;
    if (!std::filesystem::exists(path, error)) throw Error(uriOrPath, std::nullopt, "no such file or folder");
    if (std::filesystem::is_directory(path, error)) {
        if (std::filesystem::exists(path / kRecordingHeaderFile)) return detail::openRecordingSource(path, options);
        if (std::filesystem::exists(path / "rgb.txt") || std::filesystem::exists(path / "depth.txt"))
            return detail::openTumSource(path, options);
        throw Error(uriOrPath, std::nullopt,
                    std::string("folder is neither a lightskin recording (no ") + kRecordingHeaderFile +
                        ") nor a TUM RGB-D folder (no rgb.txt/depth.txt)");
    }
    std::string extension = path.extension().string();
    for (char& c : extension) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (extension == ".oni") return detail::openOpenNI2Source(uriOrPath, true, options);
    throw Error(uriOrPath, std::nullopt,
                "unknown source: expected a recording folder, a TUM folder, a .oni file, "
                "openni2://[uri] or freenect://<index>");
}

} // namespace

std::unique_ptr<FrameSource> openFrameSource(const std::string& uriOrPath, const FrameSourceOptions& options) {
    std::unique_ptr<FrameSource> source = openUnregistered(uriOrPath, options);
    source->enableSoftwareRegistration();
    return source;
}

void FrameSource::stampFrame(RgbdFrame& out, std::int64_t index) const {
    out.index = index;
    out.depthScaleMetres = info_.depthScaleMetres;
    out.colourIntrinsics = info_.colourIntrinsics;
    out.depthIntrinsics = info_.depthIntrinsics;
    out.registration = info_.registration;
    out.colour_T_depth = info_.colour_T_depth;
    out.groundTruth_world_T_camera.reset();
}

} // namespace lightskin::capture
