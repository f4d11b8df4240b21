#include "ImageIo.h"
#include "PngEncoder.h"
#include "RecordingFormat.h"

#include <lightskin/capture/Recording.h>
#include <lightskin/core/Error.h>
#include <lightskin/core/OutputMarker.h>

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <limits>
#include <unistd.h>

namespace lightskin::capture {

namespace {

/// fsync(2) of an open descriptor; throws naming `file`.
void fsyncOrThrow(int fd, const std::string& file, std::optional<std::int64_t> frame) {
    while (::fsync(fd) != 0) {
        if (errno == EINTR) continue;
        throw Error(file, frame, std::string("cannot fsync: ") + std::strerror(errno));
    }
}

/// fsync(2) of a file or folder by path (Linux flushes a file's data through any descriptor).
void fsyncPath(const std::filesystem::path& path, std::optional<std::int64_t> frame) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) throw Error(path.string(), frame, std::string("cannot open to fsync: ") + std::strerror(errno));
    try {
        fsyncOrThrow(fd, path.string(), frame);
    } catch (...) {
        ::close(fd);
        throw;
    }
    ::close(fd);
}

} // namespace

struct RecordingWriter::State {
    std::filesystem::path folder;
    RecordingInfo info;
    RecordingDurability durability;
    int indexFd = -1;
    std::int64_t frames = 0; ///< written (files in place); frames - listed wait for the next sync
    std::int64_t listed = 0; ///< in the index
    bool finished = false;
    std::vector<unsigned char> encoded; // reused between frames
    double lastTime = -std::numeric_limits<double>::infinity();
    // The batch waiting for the next sync: its index lines and its frame files (relative paths).
    // Both keep their capacity between batches, so steady-state writing does not allocate.
    std::string pendingLines;
    std::vector<std::string> pendingFiles;
    std::size_t pendingFileCount = 0;
    std::chrono::steady_clock::time_point pendingSince;

    ~State() {
        if (indexFd >= 0) ::close(indexFd);
    }

    /// Appends `lines` with one write(2); on failure truncates back to where the index ended.
    void appendLines(const std::string& lines, std::optional<std::int64_t> frame) {
        const std::string file = (folder / kRecordingIndexFile).string();
        const off_t before = ::lseek(indexFd, 0, SEEK_END);
        // One write(2): a crash leaves either the complete lines or a partial last one without its
        // newline, which readers ignore.
        const ssize_t n = ::write(indexFd, lines.data(), lines.size());
        int code = n < 0 ? errno : ENOSPC;
        bool ok = n == ssize_t(lines.size());
        if (ok && durability.fsync && ::fsync(indexFd) != 0) {
            code = errno;
            ok = false;
        }
        if (!ok) {
            if (before >= 0) {
                // Drop the partial lines; if even that fails, readers ignore a tail without newline.
                [[maybe_unused]] const int ignored = ::ftruncate(indexFd, before);
            }
            throw Error(file, frame, std::string("cannot append to the index: ") + std::strerror(code));
        }
    }

    /// Lists the waiting frames: their files and folders fsync'ed first, so the index never names a
    /// file that a power loss could take back. On failure the batch is lost (frames = listed).
    void syncPending() {
        if (frames == listed) return;
        try {
            if (durability.fsync) {
                for (std::size_t i = 0; i < pendingFileCount; ++i) fsyncPath(folder / pendingFiles[i], listed);
                // The renames into place are entries of these folders.
                fsyncPath(folder / "depth", listed);
                fsyncPath(folder / "colour", listed);
            }
            appendLines(pendingLines, listed);
        } catch (...) {
            frames = listed; // the next frame takes the first lost number: the index stays gapless
            pendingLines.clear();
            pendingFileCount = 0;
            throw;
        }
        listed = frames;
        pendingLines.clear();
        pendingFileCount = 0;
    }

    bool syncDue(std::chrono::steady_clock::time_point now) const {
        return frames > listed &&
               (frames - listed >= durability.syncEveryFrames ||
                std::chrono::duration<double>(now - pendingSince).count() >= durability.syncEverySeconds);
    }

    void addPendingFile(const std::string& relative) {
        if (pendingFileCount == pendingFiles.size()) pendingFiles.emplace_back();
        pendingFiles[pendingFileCount++].assign(relative);
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

RecordingWriter RecordingWriter::create(const std::filesystem::path& folder, const RecordingInfo& info,
                                        const RecordingDurability& durability) {
    const std::string name = folder.string();
    if (durability.syncEveryFrames < 1 || !(durability.syncEverySeconds > 0.0) ||
        !std::isfinite(durability.syncEverySeconds))
        throw Error(name, std::nullopt, "durability: syncEveryFrames must be >= 1 and syncEverySeconds > 0");
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
        if (!isEmptyOutputFolder(folder))
            throw Error(name, std::nullopt, "folder is not empty: refusing to mix a new recording into it");
    }
    std::filesystem::create_directories(folder / "depth", error);
    if (!error) std::filesystem::create_directories(folder / "colour", error);
    if (error) throw Error(name, std::nullopt, "cannot create the folder: " + error.message());

    auto state = std::make_unique<State>();
    state->folder = folder;
    state->info = info;
    state->durability = durability;
    state->pendingLines.reserve(std::size_t(std::min<std::int64_t>(durability.syncEveryFrames, 1024)) * 256);
    const std::string header = detail::headerToJson(info).dump(2) + "\n";
    detail::writeFileAtomically(folder / kRecordingHeaderFile, std::nullopt,
                                std::vector<unsigned char>(header.begin(), header.end()), durability.fsync);
    const std::string index = (folder / kRecordingIndexFile).string();
    state->indexFd = ::open(index.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (state->indexFd < 0)
        throw Error(index, std::nullopt, std::string("cannot create the index: ") + std::strerror(errno));
    if (durability.fsync) {
        // The header's rename, the index and the two frame folders are entries of `folder`, and
        // `folder` one of its parent: without these a power loss could take the recording back.
        fsyncOrThrow(state->indexFd, index, std::nullopt);
        fsyncPath(folder, std::nullopt);
        fsyncPath(std::filesystem::absolute(folder).parent_path(), std::nullopt);
    }
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
            // One fixed filter, zlib level 1: half the CPU of cv::imencode (PngEncoder.h).
            detail::encodePngFast(frame.depth, s.encoded);
            detail::writeFileAtomically(s.folder / entry.depthFile, index, s.encoded);
            s.addPendingFile(entry.depthFile);
        }
        if (frame.hasColour()) {
            if (s.info.jpegColour) {
                entry.colourFile = std::string("colour/") + stem + ".jpg";
                cv::imencode(".jpg", frame.colour, s.encoded, {cv::IMWRITE_JPEG_QUALITY, s.info.jpegQuality});
            } else {
                entry.colourFile = std::string("colour/") + stem + ".png";
                detail::encodePngFast(frame.colour, s.encoded);
            }
            detail::writeFileAtomically(s.folder / entry.colourFile, index, s.encoded);
            s.addPendingFile(entry.colourFile);
        }
    } catch (const cv::Exception& error) {
        // A file of this frame may be in pendingFiles: harmless, fsync'ing an orphan costs little.
        throw Error(name, index, std::string("cannot encode the frame: ") + error.what());
    }
    const auto now = std::chrono::steady_clock::now();
    if (s.frames == s.listed) s.pendingSince = now;
    s.pendingLines += detail::indexLine(entry);
    ++s.frames;
    if (s.syncDue(now)) s.syncPending();
}

bool RecordingWriter::syncIfDue() {
    if (!state_ || state_->finished || !state_->syncDue(std::chrono::steady_clock::now())) return false;
    state_->syncPending();
    return true;
}

void RecordingWriter::sync() {
    if (!state_ || state_->finished) return;
    state_->syncPending();
}

void RecordingWriter::finish() {
    if (!state_ || state_->finished) return;
    State& s = *state_;
    s.finished = true;
    std::optional<Error> syncError;
    try {
        s.syncPending();
    } catch (const Error& error) {
        syncError = error; // the end marker still goes in: it counts the frames that were listed
    }
    const std::string line = nlohmann::json{{"end", true}, {"frames", s.listed}}.dump() + "\n";
    s.appendLines(line, std::nullopt);
    ::close(s.indexFd);
    s.indexFd = -1;
    if (syncError) throw *syncError;
}

std::int64_t RecordingWriter::framesWritten() const { return state_ ? state_->frames : 0; }
std::int64_t RecordingWriter::framesListed() const { return state_ ? state_->listed : 0; }
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
