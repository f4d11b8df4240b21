// Reads the lightskin recording format (recordings/README.md) through the FrameSource API.
#include "ImageIo.h"
#include "RecordingFormat.h"
#include "Sources.h"

#include <lightskin/core/Error.h>

#include <cmath>

namespace lightskin::capture::detail {

namespace {

class RecordingSource final : public FrameSource {
public:
    RecordingSource(FrameSourceInfo info, FrameSourceOptions options, std::filesystem::path folder,
                    RecordingInfo header, ParsedIndex index)
        : FrameSource(std::move(info), std::move(options))
        , folder_(std::move(folder))
        , header_(std::move(header))
        , index_(std::move(index)) {}

    std::optional<std::int64_t> frameCount() const override { return std::int64_t(index_.entries.size()); }
    bool canSeek() const noexcept override { return true; }

protected:
    bool readNext(RgbdFrame& out) override {
        if (next_ >= std::int64_t(index_.entries.size())) return false;
        const IndexEntry& entry = index_.entries[std::size_t(next_)];
        const cv::Size colourSize(header_.colourIntrinsics.width, header_.colourIntrinsics.height);
        const cv::Size depthSize(header_.depthIntrinsics.width, header_.depthIntrinsics.height);
        if (entry.depthFile.empty())
            out.depth.release();
        else
            readDepth16(folder_ / entry.depthFile, next_, depthSize, scratch_, out.depth);
        if (entry.colourFile.empty())
            out.colour.release();
        else
            readColour8(folder_ / entry.colourFile, next_, colourSize, scratch_, out.colour);
        stampFrame(out, next_);
        out.colourTimestampSeconds = entry.colourTimestamp;
        out.depthTimestampSeconds = entry.depthTimestamp;
        out.groundTruth_world_T_camera = entry.world_T_camera;
        ++next_;
        return true;
    }
    std::optional<double> peekNextTimestamp() const override {
        if (next_ >= std::int64_t(index_.entries.size())) return std::nullopt;
        const IndexEntry& entry = index_.entries[std::size_t(next_)];
        return std::isfinite(entry.depthTimestamp) ? entry.depthTimestamp : entry.colourTimestamp;
    }
    bool skipNext() override {
        if (next_ >= std::int64_t(index_.entries.size())) return false;
        ++next_;
        return true;
    }
    void seekTo(std::int64_t index) override { next_ = index; }

private:
    std::filesystem::path folder_;
    RecordingInfo header_;
    ParsedIndex index_;
    std::int64_t next_ = 0;
    std::vector<unsigned char> scratch_;
};

} // namespace

std::unique_ptr<FrameSource> openRecordingSource(const std::filesystem::path& folder,
                                                 const FrameSourceOptions& options) {
    int version = 0;
    RecordingInfo header = readHeader(folder, version);
    ParsedIndex index = readIndex(folder);
    FrameSourceInfo info;
    info.kind = "lightskin-recording";
    info.uri = folder.string();
    info.deviceName = header.deviceName;
    info.colourIntrinsics = header.colourIntrinsics;
    info.depthIntrinsics = header.depthIntrinsics;
    info.depthScaleMetres = header.depthScaleMetres;
    info.registration = header.registration;
    info.colour_T_depth = header.colour_T_depth;
    info.calibrationSource = "recording header";
    for (const auto& entry : index.entries)
        if (entry.world_T_camera) info.hasGroundTruth = true;
    return std::make_unique<RecordingSource>(std::move(info), options, folder, std::move(header), std::move(index));
}

} // namespace lightskin::capture::detail
