#include "RecordingFormat.h"

#include "ImageIo.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/JsonError.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace lightskin::capture::detail {

namespace {

using nlohmann::json;

double number(const json& object, const char* key, const std::string& file, std::optional<std::int64_t> frame) {
    const auto it = object.find(key);
    if (it == object.end() || !it->is_number())
        throw Error(file, frame, std::string("field '") + key + "' is missing or not a number");
    const double value = it->get<double>();
    if (!std::isfinite(value)) throw Error(file, frame, std::string("field '") + key + "' is not finite");
    return value;
}

double timestampFromJson(const json& object, const char* key, const std::string& file, std::int64_t frame) {
    const auto it = object.find(key);
    if (it == object.end() || it->is_null()) return std::numeric_limits<double>::quiet_NaN();
    return number(object, key, file, frame);
}

} // namespace

json intrinsicsToJson(const CameraIntrinsics& k) {
    return {{"width", k.width}, {"height", k.height},        {"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx},
            {"cy", k.cy},       {"distortion", k.distortion}};
}

CameraIntrinsics intrinsicsFromJson(const json& value, const std::string& file, const std::string& key) {
    if (!value.is_object())
        throw Error(file, std::nullopt, "'" + key + "' must be an object with width, height, fx, fy, cx, cy");
    CameraIntrinsics k;
    const double width = number(value, "width", file, std::nullopt),
                 height = number(value, "height", file, std::nullopt);
    if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide || width != std::floor(width) ||
        height != std::floor(height))
        throw Error(file, std::nullopt,
                    "'" + key + "' has an absurd image size " + std::to_string(width) + "x" + std::to_string(height) +
                        " (accepted: whole numbers 1.." + std::to_string(kMaxImageSide) + ")");
    k.width = int(width);
    k.height = int(height);
    k.fx = number(value, "fx", file, std::nullopt);
    k.fy = number(value, "fy", file, std::nullopt);
    k.cx = number(value, "cx", file, std::nullopt);
    k.cy = number(value, "cy", file, std::nullopt);
    if (const auto it = value.find("distortion"); it != value.end()) {
        if (!it->is_array() || it->size() != 5)
            throw Error(file, std::nullopt, "'" + key + ".distortion' must be 5 numbers (k1 k2 p1 p2 k3)");
        for (std::size_t i = 0; i < 5; ++i) {
            if (!(*it)[i].is_number()) throw Error(file, std::nullopt, "'" + key + ".distortion' must be numbers");
            k.distortion[i] = (*it)[i].get<double>();
        }
    }
    if (!k.isValid()) throw Error(file, std::nullopt, "'" + key + "' intrinsics are invalid (zero focal length?)");
    return k;
}

json poseToJson(const Pose& pose) {
    const auto& q = pose.rotation();
    const auto& t = pose.translation();
    return {{"rotationXYZW", {q.x, q.y, q.z, q.w}}, {"translation", {t.x, t.y, t.z}}};
}

Pose poseFromJson(const json& value, const std::string& file, std::optional<std::int64_t> frame) {
    const auto fail = [&] {
        throw Error(file, frame, "pose must be {\"rotationXYZW\": [4 numbers], \"translation\": [3 numbers]}");
    };
    if (!value.is_object()) fail();
    const auto q = value.find("rotationXYZW"), t = value.find("translation");
    if (q == value.end() || t == value.end() || !q->is_array() || !t->is_array() || q->size() != 4 || t->size() != 3)
        fail();
    double v[7];
    for (std::size_t i = 0; i < 7; ++i) {
        const json& item = i < 4 ? (*q)[i] : (*t)[i - 4];
        if (!item.is_number()) fail();
        v[i] = item.get<double>();
        if (!std::isfinite(v[i])) fail();
    }
    const double norm = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
    if (std::abs(norm - 1.0) > 1e-3) throw Error(file, frame, "pose rotation quaternion is not unit length");
    return Pose(glm::dquat(v[3], v[0], v[1], v[2]), glm::dvec3(v[4], v[5], v[6]));
}

json timestampToJson(double seconds) { return std::isfinite(seconds) ? json(seconds) : json(nullptr); }

json headerToJson(const RecordingInfo& info) {
    return {{"format", "lightskin-recording"},
            {"version", kRecordingFormatVersion},
            {"device", info.deviceName},
            {"colour", intrinsicsToJson(info.colourIntrinsics)},
            {"depth", intrinsicsToJson(info.depthIntrinsics)},
            {"depthScaleMetres", info.depthScaleMetres},
            {"registration", toString(info.registration)},
            {"colour_T_depth", poseToJson(info.colour_T_depth)},
            {"colourEncoding", info.jpegColour ? "jpeg" : "png"},
            {"depthEncoding", "png16"}};
}

RecordingInfo readHeader(const std::filesystem::path& folder, int& version) {
    const std::filesystem::path path = folder / kRecordingHeaderFile;
    const std::string file = path.string();
    std::vector<unsigned char> bytes;
    readFileBounded(path, std::nullopt, kMaxHeaderBytes, bytes);
    json header;
    try {
        header = json::parse(bytes.begin(), bytes.end());
    } catch (const json::exception& error) {
        throw Error(file, std::nullopt, "malformed JSON: " + jsonErrorCause(error.what()));
    }
    // Not header.value("format", ...): it throws a json type_error outside the try below when
    // "format" is not a string (a fuzz finding).
    const auto format = header.find("format");
    if (!header.is_object() || format == header.end() || !format->is_string() || *format != "lightskin-recording")
        throw Error(file, std::nullopt,
                    "not a lightskin recording header (\"format\" must be \"lightskin-recording\")");
    const double versionNumber = number(header, "version", file, std::nullopt);
    if (versionNumber < 1 || versionNumber > kRecordingFormatVersion || versionNumber != std::floor(versionNumber))
        throw Error(file, std::nullopt,
                    "format version " + std::to_string(versionNumber) + " is not supported (this build reads 1.." +
                        std::to_string(kRecordingFormatVersion) + ")");
    version = int(versionNumber);
    RecordingInfo info;
    try {
        info.deviceName = header.value("device", std::string());
        if (!header.contains("colour") || !header.contains("depth"))
            throw Error(file, std::nullopt, "header needs 'colour' and 'depth' intrinsics");
        info.colourIntrinsics = intrinsicsFromJson(header["colour"], file, "colour");
        info.depthIntrinsics = intrinsicsFromJson(header["depth"], file, "depth");
        info.depthScaleMetres = number(header, "depthScaleMetres", file, std::nullopt);
        if (!(info.depthScaleMetres > 0.0)) throw Error(file, std::nullopt, "'depthScaleMetres' must be positive");
        const std::string registration = header.value("registration", std::string());
        if (registration == toString(DepthRegistration::RegisteredToColour))
            info.registration = DepthRegistration::RegisteredToColour;
        else if (registration == toString(DepthRegistration::Unregistered))
            info.registration = DepthRegistration::Unregistered;
        else
            throw Error(file, std::nullopt, "'registration' must be \"registered-to-colour\" or \"unregistered\"");
        if (header.contains("colour_T_depth"))
            info.colour_T_depth = poseFromJson(header["colour_T_depth"], file, std::nullopt);
        const std::string encoding = header.value("colourEncoding", std::string("png"));
        if (encoding != "png" && encoding != "jpeg")
            throw Error(file, std::nullopt, "'colourEncoding' must be \"png\" or \"jpeg\"");
        info.jpegColour = encoding == "jpeg";
    } catch (const json::exception& error) {
        throw Error(file, std::nullopt, "malformed header: " + jsonErrorCause(error.what()));
    }
    if (info.registration == DepthRegistration::RegisteredToColour &&
        (info.colourIntrinsics.width != info.depthIntrinsics.width ||
         info.colourIntrinsics.height != info.depthIntrinsics.height))
        throw Error(file, std::nullopt, "depth is marked registered to colour but the two streams' sizes differ");
    return info;
}

std::string indexLine(const IndexEntry& entry) {
    json line{{"frame", entry.frame},
              {"colourTime", timestampToJson(entry.colourTimestamp)},
              {"depthTime", timestampToJson(entry.depthTimestamp)}};
    if (!entry.colourFile.empty()) line["colour"] = entry.colourFile;
    if (!entry.depthFile.empty()) line["depth"] = entry.depthFile;
    if (entry.world_T_camera) line["world_T_camera"] = poseToJson(*entry.world_T_camera);
    // dump() of doubles is round-trip exact (shortest representation that parses back the same).
    return line.dump() + "\n";
}

ParsedIndex readIndex(const std::filesystem::path& folder) {
    const std::filesystem::path path = folder / kRecordingIndexFile;
    const std::string file = path.string();
    ParsedIndex index;
    if (!std::filesystem::exists(path)) return index; // header written, no frame yet
    std::vector<unsigned char> bytes;
    readFileBounded(path, std::nullopt, kMaxIndexBytes, bytes);
    std::size_t begin = 0;
    double lastTime = -std::numeric_limits<double>::infinity();
    std::int64_t lineNumber = 0; // in the file, from 1 (messages name it: the parser counts from each line)
    while (begin < bytes.size()) {
        ++lineNumber;
        std::size_t end = begin;
        while (end < bytes.size() && bytes[end] != '\n') ++end;
        const std::int64_t expectedFrame = std::int64_t(index.entries.size());
        if (end == bytes.size()) { // no newline: the writer was cut off in the middle of this line
            index.partialTail = true;
            break;
        }
        // A power loss during the last append can leave the file longer than the data that reached
        // the disk, the gap read back as NUL bytes (which JSON never holds): a torn last line.
        if (end + 1 == bytes.size() &&
            std::find(bytes.begin() + std::ptrdiff_t(begin), bytes.begin() + std::ptrdiff_t(end), '\0') !=
                bytes.begin() + std::ptrdiff_t(end)) {
            index.partialTail = true;
            break;
        }
        if (end - begin > kMaxIndexLineBytes)
            throw Error(file, expectedFrame,
                        "index line is " + std::to_string(end - begin) + " bytes, more than the " +
                            std::to_string(kMaxIndexLineBytes) + " accepted");
        if (index.finished) throw Error(file, expectedFrame, "lines after the end marker");
        json line;
        try {
            line = json::parse(bytes.begin() + std::ptrdiff_t(begin), bytes.begin() + std::ptrdiff_t(end));
        } catch (const json::exception& error) {
            // The parser saw one line: its "at line 1, column C" is column C of this file's line.
            std::string what = jsonErrorCause(error.what());
            if (const auto at = what.find("at line 1, "); at != std::string::npos)
                what.replace(at, std::strlen("at line 1, "), "at ");
            throw Error(file, expectedFrame, "line " + std::to_string(lineNumber) + ": malformed index line: " + what);
        }
        begin = end + 1;
        if (!line.is_object()) throw Error(file, expectedFrame, "index line is not a JSON object");
        // Not line.value("end", false): a non-boolean "end" would throw a json type_error here.
        if (const auto marker = line.find("end"); marker != line.end()) {
            if (!marker->is_boolean() || !marker->get<bool>())
                throw Error(file, expectedFrame, "'end' must be true (the end marker line)");
            // The writer states how many frames it finished: a different count means lost lines.
            if (const auto frames = line.find("frames");
                frames != line.end() && !(frames->is_number() && *frames == index.entries.size()))
                throw Error(file, std::nullopt,
                            "the end marker counts " + frames->dump() + " frames, the index holds " +
                                std::to_string(index.entries.size()));
            index.finished = true;
            continue;
        }
        try {
            IndexEntry entry;
            const double frame = number(line, "frame", file, expectedFrame);
            if (frame != double(expectedFrame))
                throw Error(file, expectedFrame,
                            "frame number " + line["frame"].dump() + " where " + std::to_string(expectedFrame) +
                                " was expected (frames are numbered 0, 1, 2, ...: out of order, repeated or missing)");
            entry.frame = expectedFrame;
            entry.colourTimestamp = timestampFromJson(line, "colourTime", file, expectedFrame);
            entry.depthTimestamp = timestampFromJson(line, "depthTime", file, expectedFrame);
            const double time = std::isfinite(entry.depthTimestamp) ? entry.depthTimestamp : entry.colourTimestamp;
            if (std::isfinite(time)) {
                if (time < lastTime)
                    throw Error(file, expectedFrame,
                                "timestamps go backwards (" + std::to_string(time) + " s after " +
                                    std::to_string(lastTime) + " s)");
                lastTime = time;
            }
            if (line.contains("colour")) {
                entry.colourFile = line["colour"].get<std::string>();
                resolveInside(folder, entry.colourFile, path, expectedFrame);
            }
            if (line.contains("depth")) {
                entry.depthFile = line["depth"].get<std::string>();
                resolveInside(folder, entry.depthFile, path, expectedFrame);
            }
            if (entry.colourFile.empty() && entry.depthFile.empty())
                throw Error(file, expectedFrame, "index line names neither a colour nor a depth file");
            if (line.contains("world_T_camera"))
                entry.world_T_camera = poseFromJson(line["world_T_camera"], file, expectedFrame);
            index.entries.push_back(std::move(entry));
        } catch (const json::exception& error) {
            throw Error(file, expectedFrame, "line " + std::to_string(lineNumber) + ": malformed index line: " + jsonErrorCause(error.what()));
        }
    }
    return index;
}

} // namespace lightskin::capture::detail
