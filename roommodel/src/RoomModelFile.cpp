#include <lightskin/core/Error.h>
#include <lightskin/roommodel/RoomModelFile.h>

#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <unistd.h>
#include <vector>

namespace lightskin::roommodel {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr std::string_view kMagic = "lightskin-room-model\n";
constexpr int kVersion = 1;
constexpr int kMaxViewSide = 4096;

std::uint64_t fnv1a(const char* bytes, std::size_t count) {
    std::uint64_t hash = 14695981039346656037ull;
    for (std::size_t i = 0; i < count; ++i) {
        hash ^= std::uint8_t(bytes[i]);
        hash *= 1099511628211ull;
    }
    return hash;
}

void appendUint64(std::string& out, std::uint64_t value) {
    for (int i = 0; i < 8; ++i) out.push_back(char((value >> (8 * i)) & 0xffu));
}

std::uint64_t readUint64(const std::string& bytes, std::size_t at) {
    std::uint64_t value = 0;
    for (int i = 0; i < 8; ++i) value |= std::uint64_t(std::uint8_t(bytes[at + std::size_t(i)])) << (8 * i);
    return value;
}

Json vec3(const glm::dvec3& v) { return Json::array({v.x, v.y, v.z}); }

Json gridOf(const RoomModelSettings& s) {
    return {{"boundsMin", vec3(s.boundsMin)},
            {"boundsMax", vec3(s.boundsMax)},
            {"up", vec3(s.up)},
            {"voxelSizeMetres", s.voxelSizeMetres},
            {"truncationMetres", s.truncationMetres}};
}

Json headerOf(const RoomModel& model) {
    Json views = Json::array();
    for (const FusedView& v : model.views()) {
        const glm::dquat q = v.world_T_camera.rotation();
        const CameraIntrinsics& k = v.intrinsics;
        views.push_back({{"rotationWXYZ", {q.w, q.x, q.y, q.z}},
                         {"translation", vec3(v.world_T_camera.translation())},
                         {"width", k.width},
                         {"height", k.height},
                         {"fx", k.fx},
                         {"fy", k.fy},
                         {"cx", k.cx},
                         {"cy", k.cy}});
    }
    return {{"format", "lightskin-room-model"},
            {"version", kVersion},
            {"grid", gridOf(model.settings())},
            {"depthUnitMetres", kDepthUnitMetres},
            {"views", views}};
}

/// The view's depth, quantised, appended little-endian.
void appendDepth(std::string& out, const cv::Mat& depthMetres) {
    for (int y = 0; y < depthMetres.rows; ++y) {
        const float* row = depthMetres.ptr<float>(y);
        for (int x = 0; x < depthMetres.cols; ++x) {
            const double units = std::round(double(row[x]) / kDepthUnitMetres);
            const auto value = std::uint16_t(units > 0.0 && units <= 65535.0 ? units : 0.0);
            out.push_back(char(value & 0xffu));
            out.push_back(char(value >> 8));
        }
    }
}

/// The file's bytes, once it is known to be a room model file of a plausible size (a file of any other kind is
/// never read whole).
std::string readRoomModelFile(const fs::path& file) {
    std::error_code error;
    if (!fs::exists(file, error)) throw Error(file.string(), std::nullopt, "no such room model file");
    if (!isRoomModelFile(file)) throw Error(file.string(), std::nullopt, "not a lightskin room model file");
    // The largest a valid file can be: kMaxViews views of kMaxViewSide^2 pixels, and a generous header.
    constexpr std::uintmax_t kMaxBytes =
        std::uintmax_t(RoomModel::kMaxViews) * kMaxViewSide * kMaxViewSide * 2 + (1u << 26);
    if (fs::file_size(file, error) > kMaxBytes || error)
        throw Error(file.string(), std::nullopt, "too large for a room model file");
    std::ifstream in(file, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) throw Error(file.string(), std::nullopt, "cannot be read");
    return bytes;
}

struct ParsedView {
    FusedView view;
    std::size_t offset = 0; // of its depth in the file
};

double finiteNumber(const Json& value, const std::string& what) {
    if (!value.is_number() || !std::isfinite(value.get<double>())) throw std::runtime_error(what + ": not a number");
    return value.get<double>();
}

glm::dvec3 readVec3(const Json& value, const std::string& what) {
    if (!value.is_array() || value.size() != 3) throw std::runtime_error(what + ": expected [x, y, z]");
    return {finiteNumber(value[0], what), finiteNumber(value[1], what), finiteNumber(value[2], what)};
}

FusedView readView(const Json& v, const std::string& where) {
    const auto size = [&](const char* key) {
        const Json& value = v.at(key);
        if (!value.is_number_integer() || value.get<std::int64_t>() < 1 || value.get<std::int64_t>() > kMaxViewSide)
            throw std::runtime_error(where + "/" + key + ": expected an integer in [1, 4096]");
        return int(value.get<std::int64_t>());
    };
    FusedView view;
    CameraIntrinsics& k = view.intrinsics;
    k.width = size("width");
    k.height = size("height");
    k.fx = finiteNumber(v.at("fx"), where + "/fx");
    k.fy = finiteNumber(v.at("fy"), where + "/fy");
    k.cx = finiteNumber(v.at("cx"), where + "/cx");
    k.cy = finiteNumber(v.at("cy"), where + "/cy");
    if (k.fx == 0.0 || k.fy == 0.0) throw std::runtime_error(where + ": a focal length is 0");
    const Json& q = v.at("rotationWXYZ");
    if (!q.is_array() || q.size() != 4) throw std::runtime_error(where + "/rotationWXYZ: expected [w, x, y, z]");
    const glm::dquat rotation(finiteNumber(q[0], where + "/rotationWXYZ"), finiteNumber(q[1], where + "/rotationWXYZ"),
                              finiteNumber(q[2], where + "/rotationWXYZ"), finiteNumber(q[3], where + "/rotationWXYZ"));
    if (std::abs(glm::length(rotation) - 1.0) > 1e-6)
        throw std::runtime_error(where + "/rotationWXYZ: not a unit quaternion");
    view.world_T_camera = Pose(rotation, readVec3(v.at("translation"), where + "/translation"));
    return view;
}

/// The grid key where the file and the model differ, "" when they agree.
std::string gridMismatch(const Json& grid, const RoomModelSettings& s) {
    const Json mine = gridOf(s);
    for (const auto& [key, value] : mine.items()) {
        if (!grid.contains(key)) return key;
        if (value.is_array() ? readVec3(grid.at(key), key) != readVec3(value, key)
                             : finiteNumber(grid.at(key), key) != value.get<double>())
            return key;
    }
    return "";
}

std::vector<ParsedView> parseViews(const std::string& bytes, std::size_t headerEnd, const Json& header,
                                   const RoomModelSettings& settings) {
    if (header.value("format", "") != "lightskin-room-model") throw std::runtime_error("/format: not a room model");
    if (header.value("version", 0) != kVersion)
        throw std::runtime_error("/version: expected " + std::to_string(kVersion) + " (a file of another version)");
    if (header.value("depthUnitMetres", 0.0) != kDepthUnitMetres)
        throw std::runtime_error("/depthUnitMetres: not " + std::to_string(kDepthUnitMetres));
    if (const std::string key = gridMismatch(header.at("grid"), settings); !key.empty())
        throw std::runtime_error("/grid/" + key + ": made for another room model grid (file " +
                                 header.at("grid").value(key, Json()).dump() + ", scene's roomModel " +
                                 gridOf(settings).at(key).dump() + ")");
    const Json& list = header.at("views");
    if (!list.is_array() || list.size() > RoomModel::kMaxViews)
        throw std::runtime_error("/views: expected at most " + std::to_string(RoomModel::kMaxViews) + " views");
    std::vector<ParsedView> views;
    std::size_t offset = headerEnd;
    for (std::size_t i = 0; i < list.size(); ++i) {
        const FusedView view = readView(list[i], "/views/" + std::to_string(i));
        views.push_back({view, offset});
        offset += std::size_t(view.intrinsics.width) * std::size_t(view.intrinsics.height) * 2;
    }
    if (offset + 8 != bytes.size())
        throw std::runtime_error("its size (" + std::to_string(bytes.size()) + " bytes) does not match its views (" +
                                 std::to_string(offset + 8) + " bytes)");
    return views;
}

cv::Mat depthOf(const std::string& bytes, const ParsedView& p) {
    cv::Mat depth(p.view.intrinsics.height, p.view.intrinsics.width, CV_32FC1);
    std::size_t at = p.offset;
    for (int y = 0; y < depth.rows; ++y) {
        float* row = depth.ptr<float>(y);
        for (int x = 0; x < depth.cols; ++x, at += 2) {
            const unsigned value = unsigned(std::uint8_t(bytes[at])) | (unsigned(std::uint8_t(bytes[at + 1])) << 8);
            row[x] = float(double(value) * kDepthUnitMetres);
        }
    }
    return depth;
}

} // namespace

bool isRoomModelFile(const fs::path& file) {
    std::error_code error;
    if (!fs::is_regular_file(file, error)) return false;
    std::ifstream in(file, std::ios::binary);
    std::string start(kMagic.size(), '\0');
    in.read(start.data(), std::streamsize(start.size()));
    return in.gcount() == std::streamsize(kMagic.size()) && start == kMagic;
}

void checkRoomModelDestination(const fs::path& file) {
    std::error_code error;
    const fs::path folder = file.parent_path().empty() ? fs::path(".") : file.parent_path();
    if (!fs::is_directory(folder, error))
        throw Error(file.string(), std::nullopt, "its folder " + folder.string() + " does not exist");
    if (fs::exists(fs::symlink_status(file, error)) && !isRoomModelFile(file))
        throw Error(file.string(), std::nullopt,
                    "exists and is not a lightskin room model file: not replaced (choose another path)");
}

void saveRoomModel(const RoomModel& model, const fs::path& file) {
    checkRoomModelDestination(file);
    const std::string header = headerOf(model).dump();
    std::string bytes(kMagic);
    appendUint64(bytes, header.size());
    bytes += header;
    cv::Mat depth;
    for (const FusedView& view : model.views()) {
        model.renderDepthInto(view.world_T_camera, view.intrinsics, depth);
        appendDepth(bytes, depth);
    }
    appendUint64(bytes, fnv1a(bytes.data(), bytes.size()));

    const fs::path partial =
        file.parent_path() / ("." + file.filename().string() + ".partial-" + std::to_string(getpid()));
    {
        std::ofstream out(partial, std::ios::binary | std::ios::trunc);
        out.write(bytes.data(), std::streamsize(bytes.size()));
        out.close();
        if (!out) {
            std::error_code ignored;
            fs::remove(partial, ignored);
            throw Error(file.string(), std::nullopt, "could not write the room model (disk full or no permission)");
        }
    }
    std::error_code error;
    fs::rename(partial, file, error);
    if (error) {
        std::error_code ignored;
        fs::remove(partial, ignored);
        throw Error(file.string(), std::nullopt, "could not replace it: " + error.message());
    }
}

void loadRoomModelInto(RoomModel& model, const fs::path& file) {
    const std::string bytes = readRoomModelFile(file);
    const std::size_t minimum = kMagic.size() + 8 + 8;
    if (bytes.size() < minimum) throw Error(file.string(), std::nullopt, "corrupt: cut short");
    if (fnv1a(bytes.data(), bytes.size() - 8) != readUint64(bytes, bytes.size() - 8))
        throw Error(file.string(), std::nullopt, "corrupt: its checksum does not match (changed or cut short)");
    const std::uint64_t headerBytes = readUint64(bytes, kMagic.size());
    if (headerBytes > bytes.size() - minimum)
        throw Error(file.string(), std::nullopt, "corrupt: its header is cut short");
    const std::size_t headerStart = kMagic.size() + 8, headerEnd = headerStart + std::size_t(headerBytes);
    std::vector<ParsedView> views;
    try {
        const Json header =
            Json::parse(bytes.begin() + std::ptrdiff_t(headerStart), bytes.begin() + std::ptrdiff_t(headerEnd));
        views = parseViews(bytes, headerEnd, header, model.settings());
    } catch (const std::exception& error) { // nlohmann's type and key errors, and ours
        throw Error(file.string(), std::nullopt, std::string("bad room model header: ") + error.what());
    }
    model.reset();
    for (const ParsedView& p : views) model.integrate(depthOf(bytes, p), p.view.intrinsics, p.view.world_T_camera);
}

} // namespace lightskin::roommodel
