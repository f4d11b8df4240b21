// TUM RGB-D layout: rgb.txt, depth.txt ("timestamp path" lines, '#' comments), optional
// groundtruth.txt ("timestamp tx ty tz qx qy qz qw", colour camera to world), optional sidecar
// lightskin-camera.json with intrinsics and depth scale. Pairs colour and depth by nearest
// timestamp like TUM's associate.py: all pairs closer than the limit, greedily by smallest
// difference, each image used once, then in time order.
#include "ImageIo.h"
#include "RecordingFormat.h"
#include "Sources.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/JsonError.h>
#include <lightskin/core/Log.h>

#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace lightskin::capture::detail {

namespace {

inline constexpr std::uintmax_t kMaxListBytes = std::uintmax_t{64} << 20;
inline constexpr const char* kSidecarFile = "lightskin-camera.json";

struct Stamped {
    double time = 0.0;
    std::string file;
};

struct StampedPose {
    double time = 0.0;
    Pose pose;
};

/// Splits a list file into its data lines; calls `parse(lineNumber, tokens)` for each.
template <typename Parse>
void forEachLine(const std::filesystem::path& path, Parse&& parse) {
    std::vector<unsigned char> bytes;
    readFileBounded(path, std::nullopt, kMaxListBytes, bytes);
    std::string text(bytes.begin(), bytes.end());
    std::istringstream stream(text);
    std::string line;
    int lineNumber = 0;
    while (std::getline(stream, line)) {
        ++lineNumber;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const auto first = line.find_first_not_of(" \t");
        if (first == std::string::npos || line[first] == '#') continue;
        std::istringstream fields(line);
        std::vector<std::string> tokens;
        std::string token;
        while (fields >> token) tokens.push_back(token);
        parse(lineNumber, tokens);
    }
}

double parseNumber(const std::string& token, const std::filesystem::path& path, int lineNumber) {
    std::size_t used = 0;
    double value = 0.0;
    try {
        value = std::stod(token, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (used != token.size() || !std::isfinite(value))
        throw Error(path.string(), std::nullopt,
                    "line " + std::to_string(lineNumber) + ": '" + token + "' is not a number");
    return value;
}

std::vector<Stamped> readImageList(const std::filesystem::path& folder, const char* name) {
    const std::filesystem::path path = folder / name;
    std::vector<Stamped> list;
    forEachLine(path, [&](int lineNumber, const std::vector<std::string>& tokens) {
        if (tokens.size() != 2)
            throw Error(path.string(), std::nullopt,
                        "line " + std::to_string(lineNumber) + ": expected 'timestamp file', got " +
                            std::to_string(tokens.size()) + " fields");
        Stamped item{parseNumber(tokens[0], path, lineNumber), tokens[1]};
        if (!list.empty() && item.time <= list.back().time)
            throw Error(path.string(), std::nullopt,
                        "line " + std::to_string(lineNumber) + ": timestamps go backwards or repeat (" + tokens[0] +
                            " after " + std::to_string(list.back().time) + ")");
        resolveInside(folder, item.file, path, std::nullopt);
        list.push_back(std::move(item));
    });
    return list;
}

std::vector<StampedPose> readGroundTruth(const std::filesystem::path& path) {
    std::vector<StampedPose> poses;
    forEachLine(path, [&](int lineNumber, const std::vector<std::string>& tokens) {
        if (tokens.size() != 8)
            throw Error(path.string(), std::nullopt,
                        "line " + std::to_string(lineNumber) + ": expected 'timestamp tx ty tz qx qy qz qw'");
        double v[8];
        for (std::size_t i = 0; i < 8; ++i) v[i] = parseNumber(tokens[i], path, lineNumber);
        const double norm = std::sqrt(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]);
        if (std::abs(norm - 1.0) > 1e-2)
            throw Error(path.string(), std::nullopt,
                        "line " + std::to_string(lineNumber) + ": quaternion is not unit length");
        if (!poses.empty() && v[0] <= poses.back().time)
            throw Error(path.string(), std::nullopt,
                        "line " + std::to_string(lineNumber) + ": timestamps go backwards or repeat");
        poses.push_back({v[0], Pose(glm::dquat(v[7], v[4], v[5], v[6]), glm::dvec3(v[1], v[2], v[3]))});
    });
    return poses;
}

struct Pair {
    std::size_t colour, depth;
};

std::vector<Pair> associate(const std::vector<Stamped>& colour, const std::vector<Stamped>& depth,
                            double maxDifference) {
    struct Candidate {
        double difference;
        std::size_t colour, depth;
    };
    std::vector<Candidate> candidates;
    std::size_t low = 0;
    for (std::size_t c = 0; c < colour.size(); ++c) {
        while (low < depth.size() && depth[low].time < colour[c].time - maxDifference) ++low;
        for (std::size_t d = low; d < depth.size() && depth[d].time <= colour[c].time + maxDifference; ++d)
            candidates.push_back({std::abs(colour[c].time - depth[d].time), c, d});
    }
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const Candidate& a, const Candidate& b) { return a.difference < b.difference; });
    std::vector<char> colourUsed(colour.size(), 0), depthUsed(depth.size(), 0);
    std::vector<Pair> pairs;
    for (const auto& candidate : candidates) {
        if (colourUsed[candidate.colour] || depthUsed[candidate.depth]) continue;
        colourUsed[candidate.colour] = depthUsed[candidate.depth] = 1;
        pairs.push_back({candidate.colour, candidate.depth});
    }
    std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.colour < b.colour; });
    return pairs;
}

/// Ground-truth pose at `time`: interpolated between the two samples around it when they are at
/// most 2 * maxDifference apart, else the nearest sample within maxDifference, else none.
std::optional<Pose> poseAt(const std::vector<StampedPose>& poses, double time, double maxDifference) {
    if (poses.empty()) return std::nullopt;
    const auto after =
        std::lower_bound(poses.begin(), poses.end(), time, [](const StampedPose& p, double t) { return p.time < t; });
    if (after != poses.end() && after->time == time) return after->pose;
    if (after != poses.begin() && after != poses.end()) {
        const auto before = after - 1;
        if (after->time - before->time <= 2.0 * maxDifference) {
            const double s = (time - before->time) / (after->time - before->time);
            return Pose(glm::slerp(before->pose.rotation(), after->pose.rotation(), s),
                        glm::mix(before->pose.translation(), after->pose.translation(), s));
        }
    }
    const StampedPose* nearest = nullptr;
    if (after != poses.end()) nearest = &*after;
    if (after != poses.begin() && (!nearest || time - (after - 1)->time < nearest->time - time))
        nearest = &*(after - 1);
    if (nearest && std::abs(nearest->time - time) <= maxDifference) return nearest->pose;
    return std::nullopt;
}

struct TumFrame {
    double colourTime = 0.0, depthTime = 0.0;
    std::string colourFile, depthFile;
    std::optional<Pose> pose;
};

class TumSource final : public FrameSource {
public:
    TumSource(FrameSourceInfo info, FrameSourceOptions options, std::filesystem::path folder,
              std::vector<TumFrame> frames)
        : FrameSource(std::move(info), std::move(options))
        , folder_(std::move(folder))
        , frames_(std::move(frames)) {}

    std::optional<std::int64_t> frameCount() const override { return std::int64_t(frames_.size()); }
    bool canSeek() const noexcept override { return true; }

protected:
    bool readNext(RgbdFrame& out) override {
        if (next_ >= std::int64_t(frames_.size())) return false;
        const TumFrame& frame = frames_[std::size_t(next_)];
        const cv::Size size(info_.colourIntrinsics.width, info_.colourIntrinsics.height);
        readDepth16(folder_ / frame.depthFile, next_, size, scratch_, out.depth);
        readColour8(folder_ / frame.colourFile, next_, size, scratch_, out.colour);
        stampFrame(out, next_);
        out.colourTimestampSeconds = frame.colourTime;
        out.depthTimestampSeconds = frame.depthTime;
        out.groundTruth_world_T_camera = frame.pose;
        ++next_;
        return true;
    }
    std::optional<double> peekNextTimestamp() const override {
        if (next_ >= std::int64_t(frames_.size())) return std::nullopt;
        return frames_[std::size_t(next_)].depthTime;
    }
    bool skipNext() override {
        if (next_ >= std::int64_t(frames_.size())) return false;
        ++next_;
        return true;
    }
    void seekTo(std::int64_t index) override { next_ = index; }

private:
    std::filesystem::path folder_;
    std::vector<TumFrame> frames_;
    std::int64_t next_ = 0;
    std::vector<unsigned char> scratch_;
};

} // namespace

std::unique_ptr<FrameSource> openTumSource(const std::filesystem::path& folder, const FrameSourceOptions& options) {
    const std::string name = folder.string();
    if (!(options.maxAssociationSeconds > 0.0)) throw Error(name, std::nullopt, "association limit must be positive");
    if (options.depthScaleMetres && !(*options.depthScaleMetres > 0.0 && std::isfinite(*options.depthScaleMetres)))
        throw Error(name, std::nullopt,
                    "depth scale must be positive and finite, got " + std::to_string(*options.depthScaleMetres));
    for (const char* list : {"rgb.txt", "depth.txt"})
        if (!std::filesystem::exists(folder / list))
            throw Error((folder / list).string(), std::nullopt,
                        "file is missing (a TUM folder needs rgb.txt and depth.txt)");

    FrameSourceInfo info;
    info.kind = "tum";
    info.uri = name;
    info.depthScaleMetres = 1.0 / 5000.0;
    info.registration = DepthRegistration::RegisteredToColour;
    std::optional<CameraIntrinsics> intrinsics = options.intrinsics;
    bool warnDefaultIntrinsics = false;
    if (const auto sidecar = folder / kSidecarFile; std::filesystem::exists(sidecar)) {
        std::vector<unsigned char> bytes;
        readFileBounded(sidecar, std::nullopt, kMaxHeaderBytes, bytes);
        try {
            const auto json = nlohmann::json::parse(bytes.begin(), bytes.end());
            if (!json.is_object()) throw Error(sidecar.string(), std::nullopt, "must be a JSON object");
            if (!intrinsics && json.contains("colour"))
                intrinsics = intrinsicsFromJson(json["colour"], sidecar.string(), "colour");
            if (json.contains("depthScaleMetres")) {
                const auto& scale = json["depthScaleMetres"];
                if (!scale.is_number() || !(scale.get<double>() > 0.0) || !std::isfinite(scale.get<double>()))
                    throw Error(sidecar.string(), std::nullopt, "'depthScaleMetres' must be a positive number");
                info.depthScaleMetres = json["depthScaleMetres"].get<double>();
            }
            if (json.contains("device")) {
                if (!json["device"].is_string())
                    throw Error(sidecar.string(), std::nullopt, "'device' must be a string");
                info.deviceName = json["device"].get<std::string>();
            }
        } catch (const nlohmann::json::exception& error) {
            throw Error(sidecar.string(), std::nullopt, "malformed JSON: " + jsonErrorCause(error.what()));
        }
    }
    if (options.depthScaleMetres) info.depthScaleMetres = *options.depthScaleMetres;
    if (!intrinsics) {
        // TUM sequence folders are named rgbd_dataset_freiburgN_*: use that camera's calibration.
        const std::string folderName = std::filesystem::absolute(folder).lexically_normal().filename().string();
        if (folderName.find("freiburg1") != std::string::npos)
            intrinsics = CameraIntrinsics::tumFreiburg1();
        else if (folderName.find("freiburg2") != std::string::npos)
            intrinsics = CameraIntrinsics::tumFreiburg2();
        else if (folderName.find("freiburg3") != std::string::npos)
            intrinsics = CameraIntrinsics::tumFreiburg3();
        else {
            intrinsics = CameraIntrinsics::kinectV1Default();
            warnDefaultIntrinsics = true;
        }
        if (info.deviceName.empty()) info.deviceName = "TUM RGB-D (Kinect v1)";
    }
    info.colourIntrinsics = info.depthIntrinsics = *intrinsics;

    const auto colour = readImageList(folder, "rgb.txt");
    const auto depth = readImageList(folder, "depth.txt");
    std::vector<StampedPose> groundTruth;
    if (std::filesystem::exists(folder / "groundtruth.txt")) groundTruth = readGroundTruth(folder / "groundtruth.txt");
    const auto pairs = associate(colour, depth, options.maxAssociationSeconds);
    if (pairs.empty())
        throw Error(name, std::nullopt,
                    "no colour and depth images within " + std::to_string(options.maxAssociationSeconds) +
                        " s of each other (rgb.txt " + std::to_string(colour.size()) + " lines, depth.txt " +
                        std::to_string(depth.size()) + ")");
    std::vector<TumFrame> frames;
    frames.reserve(pairs.size());
    for (const Pair& pair : pairs) {
        TumFrame frame;
        frame.colourTime = colour[pair.colour].time;
        frame.depthTime = depth[pair.depth].time;
        frame.colourFile = colour[pair.colour].file;
        frame.depthFile = depth[pair.depth].file;
        frame.pose = poseAt(groundTruth, frame.colourTime, options.maxAssociationSeconds);
        info.hasGroundTruth = info.hasGroundTruth || frame.pose.has_value();
        frames.push_back(std::move(frame));
    }
    if (warnDefaultIntrinsics)
        log::warning(name + ": no intrinsics given (option, " + kSidecarFile +
                     " or a freiburgN folder name): using the Kinect v1 default 525/525/319.5/239.5");
    return std::make_unique<TumSource>(std::move(info), options, folder, std::move(frames));
}

} // namespace lightskin::capture::detail
