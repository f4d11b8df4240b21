#pragma once
// Reading and writing the pieces of the lightskin recording format (recordings/README.md):
// the JSON header and the JSON-lines frame index.

#include <lightskin/capture/Recording.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace lightskin::capture::detail {

inline constexpr std::uintmax_t kMaxHeaderBytes = 1u << 20;
inline constexpr std::uintmax_t kMaxIndexBytes = std::uintmax_t{1} << 30;
inline constexpr std::size_t kMaxIndexLineBytes = 64u << 10;

nlohmann::json intrinsicsToJson(const CameraIntrinsics& intrinsics);
CameraIntrinsics intrinsicsFromJson(const nlohmann::json& value, const std::string& file, const std::string& key);
nlohmann::json poseToJson(const Pose& pose);
Pose poseFromJson(const nlohmann::json& value, const std::string& file, std::optional<std::int64_t> frame);
/// Timestamps: JSON number, or null for "unknown" (NaN in memory).
nlohmann::json timestampToJson(double seconds);

nlohmann::json headerToJson(const RecordingInfo& info);
/// Reads and checks the header file of `folder`; `version` receives the format version.
RecordingInfo readHeader(const std::filesystem::path& folder, int& version);

struct IndexEntry {
    std::int64_t frame = 0;
    double colourTimestamp = 0.0; ///< NaN when unknown
    double depthTimestamp = 0.0;
    std::string colourFile; ///< relative to the folder; empty = no colour in this frame
    std::string depthFile;
    std::optional<Pose> world_T_camera;
};

std::string indexLine(const IndexEntry& entry);

struct ParsedIndex {
    std::vector<IndexEntry> entries;
    bool finished = false;    ///< the end marker line was found
    bool partialTail = false; ///< the last line was torn (no newline, or NUL bytes) and was ignored
};
/// Parses the index of `folder`: complete lines only; throws on a malformed complete line,
/// frame numbers out of order, timestamps going backwards or paths leaving the folder.
ParsedIndex readIndex(const std::filesystem::path& folder);

} // namespace lightskin::capture::detail
