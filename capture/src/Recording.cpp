#include "ImageIo.h"
#include "RecordingFormat.h"

#include <lightskin/capture/Recording.h>
#include <lightskin/core/Error.h>

#include <opencv2/imgcodecs.hpp>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <limits>
#include <unistd.h>

namespace lightskin::capture {

struct RecordingWriter::State {
    std::filesystem::path folder;
    RecordingInfo info;
    int indexFd = -1;
    std::int64_t frames = 0;
    bool finished = false;
    std::vector<unsigned char> encoded; // reused between frames
    double lastTime = -std::numeric_limits<double>::infinity();

    ~State() {
        if (indexFd >= 0) ::close(indexFd);
    }

    void appendLine(const std::string& line, std::optional<std::int64_t> frame) {
        const std::string file = (folder / kRecordingIndexFile).string();
        const off_t before = ::lseek(indexFd, 0, SEEK_END);
        // One write(2) of the whole line: a crash leaves either the complete line or a partial
        // one without its newline, which readers ignore.
        const ssize_t n = ::write(indexFd, line.data(), line.size());
        if (n != ssize_t(line.size())) {
            const int code = n < 0 ? errno : ENOSPC;
            if (before >= 0) {
                // Drop the partial line; if even that fails, readers ignore a tail without newline.
                [[maybe_unused]] const int ignored = ::ftruncate(indexFd, before);
            }
            throw Error(file, frame, std::string("cannot append to the index: ") + std::strerror(code));
        }
    }
};

RecordingWriter::RecordingWriter(std::unique_ptr<State> state)
    : state_(std::move(state)) {}
RecordingWriter::RecordingWriter(RecordingWriter&&) noexcept = default;
RecordingWriter& RecordingWriter::operator=(RecordingWriter&& other) noexcept {
    if (this != &other) {
        if (state_) {
            try {
                finish();
            } catch (const Error&) { /* the recording stays readable up to its last frame */
            }
        }
        state_ = std::move(other.state_);
    }
    return *this;
}

RecordingWriter::~RecordingWriter() {
    if (!state_) return;
    try {
        finish();
    } catch (const Error&) { /* destructors do not throw; the frames written so far stay readable */
    }
}

RecordingWriter RecordingWriter::create(const std::filesystem::path& folder, const RecordingInfo& info) {
    const std::string name = folder.string();
    if (!info.colourIntrinsics.isValid() || !info.depthIntrinsics.isValid())
        throw Error(name, std::nullopt, "recording info needs valid colour and depth intrinsics");
    if (!(info.depthScaleMetres > 0.0) || !std::isfinite(info.depthScaleMetres))
        throw Error(name, std::nullopt, "depth scale must be positive and finite");
    if (info.registration == DepthRegistration::RegisteredToColour &&
        (info.colourIntrinsics.width != info.depthIntrinsics.width ||
         info.colourIntrinsics.height != info.depthIntrinsics.height))
        throw Error(name, std::nullopt, "depth is marked registered to colour but the two streams' sizes differ");
    if (info.jpegQuality < 1 || info.jpegQuality > 100) throw Error(name, std::nullopt, "JPEG quality must be 1..100");
    std::error_code error;
    if (std::filesystem::exists(folder, error)) {
        if (!std::filesystem::is_directory(folder)) throw Error(name, std::nullopt, "exists and is not a folder");
        if (!std::filesystem::is_empty(folder))
            throw Error(name, std::nullopt, "folder is not empty: refusing to mix a new recording into it");
    }
    std::filesystem::create_directories(folder / "depth", error);
    if (!error) std::filesystem::create_directories(folder / "colour", error);
    if (error) throw Error(name, std::nullopt, "cannot create the folder: " + error.message());

    auto state = std::make_unique<State>();
    state->folder = folder;
    state->info = info;
    const std::string header = detail::headerToJson(info).dump(2) + "\n";
    detail::writeFileAtomically(folder / kRecordingHeaderFile, std::nullopt,
                                std::vector<unsigned char>(header.begin(), header.end()));
    const std::string index = (folder / kRecordingIndexFile).string();
    state->indexFd = ::open(index.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (state->indexFd < 0)
        throw Error(index, std::nullopt, std::string("cannot create the index: ") + std::strerror(errno));
    return RecordingWriter(std::move(state));
}

void RecordingWriter::write(const RgbdFrame& frame) {
    LIGHTSKIN_ASSERT(state_, "write() on a moved-from RecordingWriter");
    State& s = *state_;
    const std::string name = s.folder.string();
    const std::int64_t index = s.frames;
    if (s.finished) throw Error(name, index, "write() after finish()");
    if (!frame.hasColour() && !frame.hasDepth()) throw Error(name, index, "frame has neither colour nor depth");
    if (frame.hasDepth()) {
        if (frame.depth.type() != CV_16UC1)
            throw Error(name, index,
                        "depth must be 16-bit single-channel, got " + detail::describeMatType(frame.depth.type()));
        if (frame.depth.cols != s.info.depthIntrinsics.width || frame.depth.rows != s.info.depthIntrinsics.height)
            throw Error(name, index,
                        "depth is " + std::to_string(frame.depth.cols) + "x" + std::to_string(frame.depth.rows) +
                            " but the recording's depth stream is " + std::to_string(s.info.depthIntrinsics.width) +
                            "x" + std::to_string(s.info.depthIntrinsics.height));
        if (std::abs(frame.depthScaleMetres - s.info.depthScaleMetres) > 1e-12 * s.info.depthScaleMetres)
            throw Error(name, index, "frame depth scale differs from the recording's");
    }
    if (frame.hasColour()) {
        if (frame.colour.type() != CV_8UC3)
            throw Error(name, index,
                        "colour must be 8-bit 3-channel BGR, got " + detail::describeMatType(frame.colour.type()));
        if (frame.colour.cols != s.info.colourIntrinsics.width || frame.colour.rows != s.info.colourIntrinsics.height)
            throw Error(name, index,
                        "colour is " + std::to_string(frame.colour.cols) + "x" + std::to_string(frame.colour.rows) +
                            " but the recording's colour stream is " + std::to_string(s.info.colourIntrinsics.width) +
                            "x" + std::to_string(s.info.colourIntrinsics.height));
    }
    const double time =
        std::isfinite(frame.depthTimestampSeconds) ? frame.depthTimestampSeconds : frame.colourTimestampSeconds;
    if (std::isfinite(time)) {
        if (time < s.lastTime) throw Error(name, index, "timestamps go backwards");
        s.lastTime = time;
    }

    char stem[32];
    std::snprintf(stem, sizeof stem, "%06lld", static_cast<long long>(index));
    detail::IndexEntry entry;
    entry.frame = index;
    entry.colourTimestamp = frame.colourTimestampSeconds;
    entry.depthTimestamp = frame.depthTimestampSeconds;
    entry.world_T_camera = frame.groundTruth_world_T_camera;
    try {
        if (frame.hasDepth()) {
            entry.depthFile = std::string("depth/") + stem + ".png";
            // Level 1: fastest zlib setting; depth compresses little better at higher levels.
            cv::imencode(".png", frame.depth, s.encoded, {cv::IMWRITE_PNG_COMPRESSION, 1});
            detail::writeFileAtomically(s.folder / entry.depthFile, index, s.encoded);
        }
        if (frame.hasColour()) {
            if (s.info.jpegColour) {
                entry.colourFile = std::string("colour/") + stem + ".jpg";
                cv::imencode(".jpg", frame.colour, s.encoded, {cv::IMWRITE_JPEG_QUALITY, s.info.jpegQuality});
            } else {
                entry.colourFile = std::string("colour/") + stem + ".png";
                cv::imencode(".png", frame.colour, s.encoded, {cv::IMWRITE_PNG_COMPRESSION, 1});
            }
            detail::writeFileAtomically(s.folder / entry.colourFile, index, s.encoded);
        }
    } catch (const cv::Exception& error) {
        throw Error(name, index, std::string("cannot encode the frame: ") + error.what());
    }
    s.appendLine(detail::indexLine(entry), index);
    ++s.frames;
}

void RecordingWriter::finish() {
    if (!state_ || state_->finished) return;
    state_->finished = true;
    const std::string line = nlohmann::json{{"end", true}, {"frames", state_->frames}}.dump() + "\n";
    state_->appendLine(line, std::nullopt);
    ::close(state_->indexFd);
    state_->indexFd = -1;
}

std::int64_t RecordingWriter::framesWritten() const { return state_ ? state_->frames : 0; }
const std::filesystem::path& RecordingWriter::folder() const {
    LIGHTSKIN_ASSERT(state_, "folder() on a moved-from RecordingWriter");
    return state_->folder;
}
const RecordingInfo& RecordingWriter::info() const {
    LIGHTSKIN_ASSERT(state_, "info() on a moved-from RecordingWriter");
    return state_->info;
}

RecordingSummary readRecordingSummary(const std::filesystem::path& folder) {
    RecordingSummary summary;
    summary.info = detail::readHeader(folder, summary.version);
    const detail::ParsedIndex index = detail::readIndex(folder);
    summary.frameCount = std::int64_t(index.entries.size());
    summary.finished = index.finished;
    summary.firstTimestampSeconds = summary.lastTimestampSeconds = std::numeric_limits<double>::quiet_NaN();
    std::error_code error;
    for (const char* file : {kRecordingHeaderFile, kRecordingIndexFile}) {
        const auto size = std::filesystem::file_size(folder / file, error);
        if (!error) summary.totalBytes += size;
    }
    for (const auto& entry : index.entries) {
        summary.framesWithColour += entry.colourFile.empty() ? 0 : 1;
        summary.framesWithDepth += entry.depthFile.empty() ? 0 : 1;
        summary.framesWithGroundTruth += entry.world_T_camera ? 1 : 0;
        for (const std::string* file : {&entry.colourFile, &entry.depthFile}) {
            if (file->empty()) continue;
            const auto size = std::filesystem::file_size(folder / *file, error);
            if (!error) summary.totalBytes += size;
        }
        const double time = std::isfinite(entry.depthTimestamp) ? entry.depthTimestamp : entry.colourTimestamp;
        if (std::isfinite(time)) {
            if (!std::isfinite(summary.firstTimestampSeconds)) summary.firstTimestampSeconds = time;
            summary.lastTimestampSeconds = time;
        }
    }
    return summary;
}

} // namespace lightskin::capture
