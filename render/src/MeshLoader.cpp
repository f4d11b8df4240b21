#include "MeshFileChecks.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/JsonError.h>
#include <lightskin/core/Log.h>
#include <lightskin/render/MeshLoader.h>

#include <assimp/BaseImporter.h>
#include <assimp/DefaultLogger.hpp>
#include <assimp/GltfMaterial.h>
#include <assimp/Importer.hpp>
#include <assimp/LogStream.hpp>
#include <assimp/ObjMaterial.h>
#include <assimp/importerdesc.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <type_traits>
#include <unordered_map>
#include <utility>
#include <vector>

namespace lightskin::render {

namespace {

bool finite(const aiVector3D& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

glm::vec3 toVec3(const aiColor3D& c) { return {c.r, c.g, c.b}; }

/// The file of `type`'s first texture, absolute; empty when there is none or it is embedded ('*n': not
/// supported, logged). A referenced file that does not exist is an error naming the mesh file, the
/// material and the texture: a missing map would silently change the light.
std::string textureFile(const aiMaterial& source, aiTextureType type, const char* what,
                        const std::filesystem::path& folder, const std::string& meshFile,
                        const std::string& materialName) {
    aiString texture;
    if (source.GetTextureCount(type) == 0 || source.GetTexture(type, 0, &texture) != AI_SUCCESS) return {};
    std::string file = texture.C_Str();
    if (file.empty()) return {};
    if (file[0] == '*') {
        log::warning(meshFile + ": material '" + materialName + "': embedded " + what + " '" + file +
                     "' ignored (only texture files are read)");
        return {};
    }
    std::replace(file.begin(), file.end(), '\\', '/');
    const std::filesystem::path path = (folder / file).lexically_normal();
    std::error_code error;
    if (!std::filesystem::is_regular_file(path, error))
        throw Error(meshFile, std::nullopt,
                    "material '" + materialName + "': " + what + " '" + path.string() + "' does not exist");
    int uvSet = 0; // glTF's texCoord: only set 0 is kept (TriangleMesh::texcoords)
    if (source.Get(AI_MATKEY_UVWSRC(type, 0), uvSet) == AI_SUCCESS && uvSet != 0)
        log::warning(meshFile + ": material '" + materialName + "': " + what + " reads texture coordinate set " +
                     std::to_string(uvSet) + "; only set 0 is loaded, so it is sampled with set 0");
    return path.string();
}

/// A finite texture factor of `key` in [low, high] (glTF strength/scale, OBJ -bm), else `fallback` (logged).
float textureFactor(const aiMaterial& source, const char* key, unsigned semantic, float fallback, float low, float high,
                    const std::string& meshFile, const std::string& materialName) {
    float value = fallback;
    if (source.Get(key, semantic, 0, value) != AI_SUCCESS) return fallback;
    if (std::isfinite(value) && value >= low && value <= high) return value;
    log::warning(meshFile + ": material '" + materialName + "': " + key + " " + std::to_string(value) + " outside [" +
                 std::to_string(low) + ", " + std::to_string(high) + "], " + std::to_string(fallback) + " used");
    return fallback;
}

Material convertMaterial(const aiMaterial& source, const std::filesystem::path& folder, std::string& name,
                         glm::vec3& emission, const std::string& meshFile) {
    Material material;
    aiString aiName;
    if (source.Get(AI_MATKEY_NAME, aiName) == AI_SUCCESS) name = aiName.C_Str();

    aiColor4D base;
    aiColor3D colour;
    if (source.Get(AI_MATKEY_BASE_COLOR, base) == AI_SUCCESS) {
        material.diffuseAlbedo = {base.r, base.g, base.b};
    } else if (source.Get(AI_MATKEY_COLOR_DIFFUSE, colour) == AI_SUCCESS) {
        material.diffuseAlbedo = toVec3(colour);
    }
    bool isGltf = false;
    {
        float metallic = 0.0f;
        isGltf = source.Get(AI_MATKEY_METALLIC_FACTOR, metallic) == AI_SUCCESS;
    }
    if (!isGltf && source.Get(AI_MATKEY_COLOR_SPECULAR, colour) == AI_SUCCESS) material.specularAlbedo = toVec3(colour);
    float shininess = 0.0f;
    if (!isGltf && source.Get(AI_MATKEY_SHININESS, shininess) == AI_SUCCESS && std::isfinite(shininess))
        material.specularExponent = std::max(1.0f, shininess);
    material.diffuseAlbedo = glm::clamp(material.diffuseAlbedo, glm::vec3(0.0f), glm::vec3(1.0f));
    material.specularAlbedo = glm::clamp(material.specularAlbedo, glm::vec3(0.0f), glm::vec3(1.0f));

    if (source.Get(AI_MATKEY_COLOR_EMISSIVE, colour) == AI_SUCCESS && (colour.r > 0 || colour.g > 0 || colour.b > 0)) {
        emission = toVec3(colour);
    } else if (source.Get(AI_MATKEY_COLOR_AMBIENT, colour) == AI_SUCCESS &&
               (colour.r > 1.0f || colour.g > 1.0f || colour.b > 1.0f)) {
        emission = toVec3(colour); // OBJ convention of some files: emission stored as Ka (see header)
    }

    aiString texture;
    aiTextureType types[] = {aiTextureType_BASE_COLOR, aiTextureType_DIFFUSE};
    for (aiTextureType type : types) {
        if (source.GetTextureCount(type) > 0 && source.GetTexture(type, 0, &texture) == AI_SUCCESS) {
            std::string file = texture.C_Str();
            if (!file.empty() && file[0] != '*') { // '*n' = embedded texture: not supported, ignored
                std::replace(file.begin(), file.end(), '\\', '/');
                material.diffuseTexture = (folder / file).lexically_normal().string();
            }
            break;
        }
    }

    // Small-scale maps (multi-scale PRT's small scale). assimp 5.2.5 hands glTF's occlusionTexture over as
    // aiTextureType_LIGHTMAP with its strength in $tex.strength, normalTexture as aiTextureType_NORMALS with its
    // scale in $tex.scale, and OBJ's norm as aiTextureType_NORMALS with -bm in $tex.bumpmult. A lightmap of
    // other formats (FBX, 3DS) is baked light, not occlusion, so LIGHTMAP counts for glTF only.
    const aiTextureType occlusionType = source.GetTextureCount(aiTextureType_AMBIENT_OCCLUSION) > 0
                                            ? aiTextureType_AMBIENT_OCCLUSION
                                        : isGltf ? aiTextureType_LIGHTMAP
                                                 : aiTextureType_NONE;
    if (occlusionType != aiTextureType_NONE) {
        material.occlusionTexture = textureFile(source, occlusionType, "occlusion texture", folder, meshFile, name);
        material.occlusionStrength =
            textureFactor(source, _AI_MATKEY_GLTF_STRENGTH_BASE, occlusionType, 1.0f, 0.0f, 1.0f, meshFile, name);
    }
    material.normalTexture = textureFile(source, aiTextureType_NORMALS, "normal texture", folder, meshFile, name);
    if (!material.normalTexture.empty()) {
        const char* key = isGltf ? _AI_MATKEY_GLTF_SCALE_BASE : _AI_MATKEY_OBJ_BUMPMULT_BASE;
        material.normalScale = textureFactor(source, key, aiTextureType_NORMALS, 1.0f, 0.0f, 100.0f, meshFile, name);
    }
    // OBJ's bump/map_Bump is a height map (aiTextureType_HEIGHT); the small scale reads occlusion and normal
    // maps only (gi/prt/include/lightskin/gi/prt/MultiscalePrt.h says why), so say that it is not used.
    if (source.GetTextureCount(aiTextureType_HEIGHT) > 0)
        log::info(meshFile + ": material '" + name + "': height map (bump) not used");
    return material;
}

std::uint64_t saturatingAdd(std::uint64_t a, std::uint64_t b) {
    std::uint64_t sum = 0;
    return __builtin_add_overflow(a, b, &sum) ? std::numeric_limits<std::uint64_t>::max() : sum;
}

std::uint64_t saturatingMultiply(std::uint64_t a, std::uint64_t b) {
    std::uint64_t product = 0;
    return __builtin_mul_overflow(a, b, &product) ? std::numeric_limits<std::uint64_t>::max() : product;
}

/// Largest value of a PLY list's count type; 0 for an unknown or non-integer type.
std::uint64_t plyCountTypeMax(const std::string& type) {
    if (type == "char" || type == "int8") return 127;
    if (type == "uchar" || type == "uint8") return 255;
    if (type == "short" || type == "int16") return 32767;
    if (type == "ushort" || type == "uint16") return 65535;
    if (type == "int" || type == "int32") return 2147483647;
    if (type == "uint" || type == "uint32") return 4294967295;
    return 0;
}

struct PlyProperty {
    bool list = false;
    std::uint64_t countMax = 0; ///< list: its count type's largest value
};
struct PlyElement {
    std::string name;
    std::uint64_t count = 0;
    std::vector<PlyProperty> properties;
};

/// Walks an ASCII PLY body, one element instance per line (as assimp reads it; "comment" lines
/// are skipped like assimp does): every list count must be a whole number within its count type.
/// assimp reads "99999999993" into a uchar count without a check and allocates for it (32 GB: fuzz
/// finding 2b). Lines with too few values are left to assimp, which reports them. A body with fewer
/// instance lines than the header's counts is refused: assimp read the last line again for the missing face,
/// so a vertex line's "99999999999993" became a list count and it allocated 2.2 GB (fuzz finding 12).
void checkPlyAsciiBody(std::istream& body, const std::vector<PlyElement>& elements, const std::string& source) {
    std::string line, token;
    for (const PlyElement& element : elements)
        for (std::uint64_t i = 0; i < element.count; ++i) {
            do {
                if (!std::getline(body, line))
                    throw Error(source, std::nullopt,
                                "ASCII PLY: the body ends before element '" + element.name + "' " + std::to_string(i) +
                                    " (the header counts " + std::to_string(element.count) +
                                    "; one line per instance)");
                // A NUL ends assimp's view of a line where this walk goes on, and the two then read
                // different values as list counts (fuzz findings 15, 16: 12 and 28 GB asked of assimp).
                if (std::any_of(line.begin(), line.end(), [](char c) {
                        return c != '\t' && c != '\r' && std::iscntrl(static_cast<unsigned char>(c)) != 0;
                    }))
                    throw Error(source, std::nullopt,
                                "ASCII PLY: control character in the line of element '" + element.name + "' " +
                                    std::to_string(i));
            } while (line.find_first_not_of(" \t\r") == std::string::npos ||
                     line.compare(line.find_first_not_of(" \t"), 7, "comment") == 0);
            std::istringstream values(line);
            // Every value on the instance's own line: assimp reads a short line's missing values from the
            // next lines, and the two walks then take different values for list counts (fuzz finding 17:
            // a list count of 232 over 3 values, then 18 GB asked of assimp).
            const auto missingValues = [&] {
                return Error(source, std::nullopt,
                             "ASCII PLY: element '" + element.name + "' " + std::to_string(i) +
                                 " has fewer values on its line than its properties need");
            };
            for (const PlyProperty& property : element.properties) {
                if (!(values >> token)) throw missingValues();
                if (!property.list) continue;
                const bool digits = token.size() <= 19 && std::all_of(token.begin(), token.end(),
                                                                      [](char c) { return c >= '0' && c <= '9'; });
                if (!digits || std::stoull(token) > property.countMax)
                    throw Error(source, std::nullopt,
                                "ASCII PLY: element '" + element.name + "' " + std::to_string(i) + ": list count '" +
                                    token.substr(0, 32) + "' is not a whole number within its count type (0.." +
                                    std::to_string(property.countMax) + ")");
                for (std::uint64_t k = std::stoull(token); k > 0; --k)
                    if (!(values >> token)) throw missingValues();
            }
        }
}

std::size_t plyTypeSize(const std::string& type) {
    if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
    if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
    if (type == "int" || type == "uint" || type == "float" || type == "int32" || type == "uint32" || type == "float32")
        return 4;
    if (type == "double" || type == "float64") return 8;
    return 0;
}

// assimp 5.2.5 loops forever on a PLY whose header is cut off, reads past the data of a truncated
// binary body, and reserves memory for the header's element counts before reading any (an ASCII
// PLY claiming 2^31 faces made it request 32 GB: a fuzz finding). Check the header, and that the
// body can hold what the counts claim, first.
void checkPlyHeader(const std::filesystem::path& path) {
    const std::string source = path.string();
    std::ifstream file(path, std::ios::binary);
    if (!file) throw Error(source, std::nullopt, "cannot open the file");
    std::string line;
    std::getline(file, line);
    if (line.rfind("ply", 0) != 0) throw Error(source, std::nullopt, "not a PLY file (no 'ply' magic line)");
    bool binary = false, ended = false;
    // Least body sizes the counts imply: binary, the properties' sizes (a list at least its count);
    // ASCII, two bytes per value (a digit and a separator; a list at least its count).
    std::uint64_t minimumBody = 0, minimumAsciiBody = 0, elementCount = 0;
    std::vector<PlyElement> elements;
    std::size_t headerBytes = line.size() + 1;
    const std::uint64_t fileBytes = std::filesystem::file_size(path);
    for (int lines = 0; lines < 10000 && std::getline(file, line); ++lines) {
        headerBytes += line.size() + 1;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        std::istringstream words(line);
        std::string keyword;
        words >> keyword;
        // assimp reads the header as C strings: a NUL ended its view of a line where ours went on
        // ("format ascii\0 1.0" was binary here and ASCII to assimp, which then took an unchecked list
        // count and allocated 11 GB: fuzz finding 14). No control bytes, and a known format only.
        const auto control = [](char c) { return c != '\t' && std::iscntrl(static_cast<unsigned char>(c)) != 0; };
        if (std::any_of(line.begin(), line.end(), control))
            throw Error(source, std::nullopt, "PLY header: control character in line " + std::to_string(lines + 2));
        if (keyword == "format") {
            std::string format;
            words >> format;
            if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian")
                throw Error(source, std::nullopt, "PLY header: unknown format '" + format.substr(0, 32) + "'");
            binary = format != "ascii";
        } else if (keyword == "element") {
            std::string name, count;
            words >> name >> count;
            // A whole decimal count only: ">> elementCount" took "1.0" as 1 and left assimp and this
            // check reading the body differently (a fuzz finding).
            if (!words || count.empty() || count.size() > 19 ||
                !std::all_of(count.begin(), count.end(), [](char c) { return c >= '0' && c <= '9'; }))
                throw Error(source, std::nullopt, "PLY header: malformed element line '" + line + "'");
            // assimp 5.2.5 does not skip an element name it does not know before reading the count, so
            // the leading digits of a name like "3333...vertex" becomes a count of billions (a 53 GB
            // allocation); a name starting with a letter gives it a count of 0.
            if (!std::isalpha(static_cast<unsigned char>(name.front())) && name.front() != '_')
                throw Error(source, std::nullopt,
                            "PLY header: element name '" + name.substr(0, 32) + "' does not start with a letter");
            elementCount = std::stoull(count);
            elements.push_back({name, elementCount, {}});
        } else if (keyword == "property") {
            std::string type;
            words >> type;
            PlyProperty property;
            if (type == "list") {
                words >> type; // the count type; at least the count is stored
                property.list = true;
                property.countMax = plyCountTypeMax(type);
            }
            if (!elements.empty()) elements.back().properties.push_back(property);
            // Saturating: a forged count must not wrap the sums around to a small size.
            minimumBody = saturatingAdd(minimumBody, saturatingMultiply(elementCount, plyTypeSize(type)));

        } else if (keyword == "end_header") {
            ended = true;
            break;
        } else if (keyword != "format" && keyword != "comment" && keyword != "obj_info" && !keyword.empty()) {
            // Unknown lines (a misspelt "property") would make this check and assimp disagree on the body.
            throw Error(source, std::nullopt, "PLY header: unknown line '" + line.substr(0, 64) + "'");
        }
    }
    if (!ended) throw Error(source, std::nullopt, "PLY header is truncated (no end_header line)");
    for (const PlyElement& element : elements) {
        // ASCII: every instance is a line, at least a byte (fuzz finding: 2^31 faces whose property
        // line was misspelt, so none counted, kept assimp reading for minutes).
        minimumAsciiBody =
            saturatingAdd(minimumAsciiBody,
                          saturatingMultiply(element.count, std::max<std::uint64_t>(1, 2 * element.properties.size())));
        if (element.properties.empty() && element.count > 0)
            throw Error(source, std::nullopt, "PLY header: element '" + element.name + "' has no properties");
    }
    if (binary) {
        if (fileBytes < saturatingAdd(headerBytes, minimumBody))
            throw Error(source, std::nullopt,
                        "binary PLY is truncated: " + std::to_string(fileBytes) + " bytes, the header needs at least " +
                            std::to_string(saturatingAdd(headerBytes, minimumBody)));
    } else if (fileBytes + 1 < saturatingAdd(headerBytes, minimumAsciiBody)) { // + 1: the last value needs no separator
        throw Error(source, std::nullopt,
                    "ASCII PLY is truncated or its element counts are wrong: " + std::to_string(fileBytes) +
                        " bytes, the header's counts need at least " +
                        std::to_string(saturatingAdd(headerBytes, minimumAsciiBody)));
    } else {
        checkPlyAsciiBody(file, elements, source); // the counts are now bounded by the file size
    }
}

bool hasExtension(const std::filesystem::path& path, const char* lower) {
    std::string extension = path.extension().string();
    for (char& c : extension) c = char(std::tolower(static_cast<unsigned char>(c)));
    return extension == lower;
}

// assimp 5.2.5 reads a glTF buffer file shorter than its byteLength with a vague error and leaks the
// open stream (found by fuzz/MeshFuzz.cpp). Check every external buffer first: present, and at
// least as long as the file declares.
void checkGltfBuffers(const std::filesystem::path& path) {
    const std::string source = path.string();
    nlohmann::json gltf;
    try {
        std::ifstream file(path, std::ios::binary);
        gltf = nlohmann::json::parse(file);
    } catch (const nlohmann::json::exception& error) {
        throw Error(source, std::nullopt, "malformed glTF JSON: " + jsonErrorCause(error.what()));
    }
    if (!gltf.is_object() || !gltf.contains("buffers")) return;
    const nlohmann::json& buffers = gltf["buffers"];
    if (!buffers.is_array()) throw Error(source, std::nullopt, "'buffers' must be an array");
    for (std::size_t i = 0; i < buffers.size(); ++i) {
        const nlohmann::json& buffer = buffers[i];
        const std::string key = "buffers[" + std::to_string(i) + "]";
        if (!buffer.is_object() || !buffer.contains("byteLength") || !buffer["byteLength"].is_number_unsigned())
            throw Error(source, std::nullopt, key + " must be an object with a whole 'byteLength'");
        if (!buffer.contains("uri")) continue; // the binary chunk of a .glb
        if (!buffer["uri"].is_string()) throw Error(source, std::nullopt, key + ".uri must be a string");
        const std::string uri = buffer["uri"].get<std::string>();
        if (uri.rfind("data:", 0) == 0) continue; // embedded base64, decoded and checked by assimp
        const std::filesystem::path file = path.parent_path() / uri;
        std::error_code error;
        if (!std::filesystem::is_regular_file(file, error))
            throw Error(source, std::nullopt, key + ": buffer file '" + uri + "' does not exist");
        const std::uintmax_t size = std::filesystem::file_size(file, error);
        const auto declared = buffer["byteLength"].get<std::uintmax_t>();
        if (error || size < declared)
            throw Error(source, std::nullopt,
                        key + ": buffer file '" + uri + "' is " + std::to_string(size) +
                            " bytes, shorter than its byteLength " + std::to_string(declared) +
                            " (truncated or corrupt)");
    }
}

// assimp 5.2.5's MTL reader dereferences its current material, which exists only after a `newmtl`
// line: a property line before the first `newmtl` crashes it (SEGV; a fuzz finding). Every line
// before the first `newmtl` must be empty or a comment.
void checkMaterialLibrary(const std::filesystem::path& path) {
    std::ifstream file(path, std::ios::binary);
    std::string line;
    for (std::int64_t number = 1; std::getline(file, line); ++number) {
        // assimp's MTL reader ends a line (and a comment) at a NUL byte, we at the newline: a comment
        // holding NULs hid material properties from this check and assimp crashed on them (SEGV, fuzz
        // finding 11). A text file has no NUL bytes.
        if (line.find('\0') != std::string::npos)
            throw Error(path.string(), std::nullopt,
                        "line " + std::to_string(number) + ": NUL byte in a text file (not a material library)");
        std::istringstream words(line);
        std::string keyword;
        if (!(words >> keyword) || keyword[0] == '#') continue;
        if (keyword == "newmtl") return;
        throw Error(path.string(), std::nullopt,
                    "line " + std::to_string(number) + ": '" + keyword.substr(0, 32) +
                        "' before the first 'newmtl' (material properties need a material)");
    }
}

// assimp's OBJ importer replaces a missing material library by a default grey material with only
// a log line: the object would render in the wrong colours without an error.
void checkObjMaterialLibraries(const std::filesystem::path& path) {
    std::ifstream file(path, std::ios::binary);
    std::string line;
    while (std::getline(file, line)) {
        if (line.rfind("mtllib", 0) != 0 || line.size() < 7 || (line[6] != ' ' && line[6] != '\t')) continue;
        std::istringstream names(line.substr(7));
        for (std::string name; names >> name;) {
            std::error_code error;
            if (!std::filesystem::is_regular_file(path.parent_path() / name, error))
                throw Error(path.string(), std::nullopt, "material library '" + name + "' (mtllib) does not exist");
            checkMaterialLibrary(path.parent_path() / name);
        }
    }
}

} // namespace

std::size_t LoadedModel::triangleCount() const noexcept {
    std::size_t n = 0;
    for (const MeshPart& part : parts) n += part.mesh.triangleCount();
    return n;
}

std::size_t LoadedModel::vertexCount() const noexcept {
    std::size_t n = 0;
    for (const MeshPart& part : parts) n += part.mesh.vertexCount();
    return n;
}

DegenerateRepair removeDegenerateTriangles(TriangleMesh& mesh) {
    DegenerateRepair repair;
    std::size_t kept = 0;
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
        const std::uint32_t i0 = mesh.indices[t], i1 = mesh.indices[t + 1], i2 = mesh.indices[t + 2];
        bool degenerate = i0 == i1 || i1 == i2 || i0 == i2;
        if (!degenerate) {
            const glm::vec3 a = mesh.positions[i0], b = mesh.positions[i1], c = mesh.positions[i2];
            degenerate = !(glm::length(glm::cross(b - a, c - a)) > 0.0f);
        }
        if (degenerate) {
            ++repair.droppedTriangles;
            continue;
        }
        mesh.indices[kept++] = i0;
        mesh.indices[kept++] = i1;
        mesh.indices[kept++] = i2;
    }
    mesh.indices.resize(kept);
    if (repair.droppedTriangles == 0) return repair;

    // Compact the vertices the remaining triangles use, keeping their order.
    constexpr std::uint32_t unused = std::numeric_limits<std::uint32_t>::max();
    std::vector<std::uint32_t> remap(mesh.positions.size(), unused);
    for (std::uint32_t index : mesh.indices) remap[index] = 0;
    std::uint32_t next = 0;
    for (std::size_t v = 0; v < remap.size(); ++v) {
        if (remap[v] == unused) continue;
        remap[v] = next;
        mesh.positions[next] = mesh.positions[v];
        if (!mesh.normals.empty()) mesh.normals[next] = mesh.normals[v];
        if (!mesh.texcoords.empty()) mesh.texcoords[next] = mesh.texcoords[v];
        ++next;
    }
    repair.removedVertices = mesh.positions.size() - next;
    mesh.positions.resize(next);
    if (!mesh.normals.empty()) mesh.normals.resize(next);
    if (!mesh.texcoords.empty()) mesh.texcoords.resize(next);
    for (std::uint32_t& index : mesh.indices) index = remap[index];
    return repair;
}

namespace {

/// assimp's log messages ("Error, T0: ...") into ours at debug level with their source ("assimp: ..."),
/// shown with -v: never on the terminal raw, and kept where a user who asks can see them.
class AssimpToLightskinLog final : public Assimp::LogStream {
public:
    void write(const char* message) override {
        std::string_view text(message);
        while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.remove_suffix(1);
        if (!text.empty()) log::debug("assimp: " + std::string(text));
    }
};

void routeAssimpLogOnce() {
    static std::once_flag once;
    std::call_once(once, [] {
        // No file, no debugger stream: only ours. Info is the importer's "Load <file>" chatter.
        Assimp::DefaultLogger::create(nullptr, Assimp::Logger::NORMAL, 0);
        Assimp::DefaultLogger::get()->attachStream(new AssimpToLightskinLog, // the logger owns it
                                                   Assimp::Logger::Warn | Assimp::Logger::Err);
    });
}

/// False only where assimp would offer the content to every reader: more than one reader lists the
/// file's extension and none of them recognises the content. One reader for the extension is taken
/// without a look at the content (assimp 5.2), and sniffing it here would refuse valid files:
/// assimp's OBJ test looks for a keyword in the first 200 bytes only, so an OBJ that opens with a
/// long comment failed it.
bool extensionReaderRecognises(const Assimp::Importer& importer, const std::filesystem::path& path) {
    std::string extension = path.extension().string();
    if (!extension.empty() && extension.front() == '.') extension.erase(0, 1);
    for (char& c : extension) c = char(std::tolower(static_cast<unsigned char>(c)));
    std::size_t listing = 0;
    bool recognised = false;
    for (std::size_t i = 0; i < importer.GetImporterCount(); ++i) {
        const aiImporterDesc* info = importer.GetImporterInfo(i);
        const Assimp::BaseImporter* reader = importer.GetImporter(i);
        if (info == nullptr || reader == nullptr || info->mFileExtensions == nullptr) continue;
        std::istringstream listed(info->mFileExtensions);
        for (std::string candidate; listed >> candidate;)
            if (candidate == extension) {
                ++listing;
                recognised = recognised || reader->CanRead(path.string(), importer.GetIOHandler(), false);
            }
    }
    return listing == 1 || recognised;
}

/// Ids of `count` vertices that two vertices share exactly when their positions are equal (a vertex split
/// at a crease or a UV seam is one corner; -0 equals +0, a NaN position is a corner of its own).
struct CornerIds {
    std::vector<std::uint32_t> id; ///< per vertex
    std::uint32_t count = 0;       ///< distinct corners, ids 0..count-1
};
template <class PositionOf>
CornerIds cornerIdsByPosition(std::size_t count, PositionOf positionOf) {
    struct PositionHash {
        std::size_t operator()(const std::array<float, 3>& p) const noexcept {
            std::size_t h = 0;
            for (float f : p) h = h * 1000003u ^ std::hash<float>{}(f);
            return h;
        }
    };
    std::unordered_map<std::array<float, 3>, std::uint32_t, PositionHash> ids;
    ids.reserve(count);
    CornerIds result;
    result.id.resize(count);
    for (std::size_t i = 0; i < count; ++i)
        result.id[i] = ids.try_emplace(positionOf(i), std::uint32_t(ids.size())).first->second;
    result.count = std::uint32_t(ids.size());
    return result;
}

/// Drops all but one of the triangles of `mesh` that span the same three corner positions (a
/// zero-thickness flap: bun_zipper_res4.ply lists 30 corner sets 2-4 times, 39 extra copies, most wound the other
/// way). Why before the normals are generated: the copy wound against its neighbours adds its
/// reversed face normal to its corners, which turns their smooth normals by up to ~170 degrees and the
/// interpolated per-pixel normal of every triangle around them by tens of degrees; under light
/// from near a receiver's horizon that turns a lit pixel black (the brute force's black
/// pixel on the PCL TIFF). The copy kept is the one whose edges run opposite to the edges of the
/// other triangles that share them (the winding its neighbours agree on); ties keep the first in the
/// file. Corners are compared by position, as assimp's readers may give each face its own vertices.
/// Returns the count dropped.
std::size_t removeDuplicateTriangles(aiMesh& mesh) {
    const CornerIds ids = cornerIdsByPosition(mesh.mNumVertices, [&](std::size_t vertex) {
        const aiVector3D& v = mesh.mVertices[vertex];
        return std::array<float, 3>{v.x, v.y, v.z};
    });
    const auto idOf = [&](unsigned vertex) { return ids.id[vertex]; };
    const unsigned faces = mesh.mNumFaces;
    std::vector<std::array<std::uint32_t, 3>> corners(faces, {0u, 0u, 0u});
    std::map<std::array<std::uint32_t, 3>, std::vector<unsigned>> bySet;
    for (unsigned f = 0; f < faces; ++f) {
        const aiFace& face = mesh.mFaces[f];
        // Not a triangle, or an index out of range: left alone here, the conversion below refuses the latter.
        if (face.mNumIndices != 3 ||
            std::max({face.mIndices[0], face.mIndices[1], face.mIndices[2]}) >= mesh.mNumVertices)
            continue;
        for (unsigned k = 0; k < 3; ++k) corners[f][k] = idOf(face.mIndices[k]);
        std::array<std::uint32_t, 3> key = corners[f];
        std::sort(key.begin(), key.end());
        if (key[0] != key[1] && key[1] != key[2]) bySet[key].push_back(f);
    }
    std::vector<char> drop(faces, 0);
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> directedEdges; // of the triangles listed once
    bool anyDuplicate = false;
    for (const auto& [key, list] : bySet) {
        if (list.size() > 1)
            anyDuplicate = true;
        else
            for (unsigned k = 0; k < 3; ++k) ++directedEdges[{corners[list[0]][k], corners[list[0]][(k + 1) % 3]}];
    }
    if (!anyDuplicate) return 0;
    const auto count = [&](std::uint32_t a, std::uint32_t b) {
        const auto it = directedEdges.find({a, b});
        return it == directedEdges.end() ? 0 : it->second;
    };
    std::size_t dropped = 0;
    for (const auto& [key, list] : bySet) {
        if (list.size() < 2) continue;
        unsigned keep = list[0];
        int best = std::numeric_limits<int>::min();
        for (unsigned f : list) {
            int agree = 0; // a neighbour's edge b -> a agrees with this copy's a -> b; a -> b disagrees
            for (unsigned k = 0; k < 3; ++k) {
                const std::uint32_t a = corners[f][k], b = corners[f][(k + 1) % 3];
                agree += count(b, a) - count(a, b);
            }
            if (agree > best) {
                best = agree;
                keep = f;
            }
        }
        for (unsigned f : list)
            if (f != keep) {
                drop[f] = 1;
                ++dropped;
            }
    }
    // Compact by swapping the index arrays: aiMesh deletes its whole face array, so the moved-out
    // faces past mNumFaces are still freed.
    unsigned next = 0;
    for (unsigned f = 0; f < faces; ++f) {
        if (drop[f]) continue;
        if (next != f) {
            std::swap(mesh.mFaces[next].mNumIndices, mesh.mFaces[f].mNumIndices);
            std::swap(mesh.mFaces[next].mIndices, mesh.mFaces[f].mIndices);
        }
        ++next;
    }
    mesh.mNumFaces = next;
    return dropped;
}

/// Gives every face corner of `mesh` its own vertex (positions and every texture-coordinate and colour set
/// copied). Why: assimp 5.2.5's GenSmoothNormals first writes each face's normal into its corners' vertex
/// slots (for a vertex shared by several faces the last face wins) and then averages only over the
/// distinct vertices at the same position; on an indexed mesh (PLY: bun_zipper_res4.ply) a shared vertex
/// so kept the normal of one adjacent face (378 of its 451 vertices), and the G-buffer's normal field
/// kinked by 2-13 degrees within 1-2 px (TUM fr3's speckle). Un-shared, each corner averages the
/// normals of all faces around its position within the crease angle, and JoinIdenticalVertices re-joins
/// the corners that end up equal. Only for a mesh without normals and without bones or morph targets
/// (their per-vertex data would need remapping; assimp's PLY, OBJ and glTF readers give such meshes
/// normals or no sharing). Returns false when left alone (also on an index out of range: refused below).
bool unshareVertices(aiMesh& mesh) {
    if (mesh.HasNormals() || mesh.HasBones() || mesh.mNumAnimMeshes > 0 || mesh.HasTangentsAndBitangents())
        return false;
    std::uint64_t corners = 0;
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
        const aiFace& face = mesh.mFaces[f];
        for (unsigned k = 0; k < face.mNumIndices; ++k)
            if (face.mIndices[k] >= mesh.mNumVertices) return false;
        corners += face.mNumIndices;
    }
    if (corners == 0 || corners > std::numeric_limits<unsigned>::max() / 2) return false;
    const auto count = static_cast<unsigned>(corners);
    // aiMesh's destructor delete[]s these arrays; each is replaced by one of the new size.
    const auto remap = [&](auto*& array) {
        using T = std::remove_pointer_t<std::remove_reference_t<decltype(array)>>;
        if (array == nullptr) return;
        T* copy = new T[count];
        unsigned next = 0;
        for (unsigned f = 0; f < mesh.mNumFaces; ++f)
            for (unsigned k = 0; k < mesh.mFaces[f].mNumIndices; ++k) copy[next++] = array[mesh.mFaces[f].mIndices[k]];
        delete[] array;
        array = copy;
    };
    remap(mesh.mVertices);
    for (auto*& set : mesh.mTextureCoords) remap(set);
    for (auto*& set : mesh.mColors) remap(set);
    unsigned next = 0;
    for (unsigned f = 0; f < mesh.mNumFaces; ++f)
        for (unsigned k = 0; k < mesh.mFaces[f].mNumIndices; ++k) mesh.mFaces[f].mIndices[k] = next++;
    mesh.mNumVertices = count;
    return true;
}

} // namespace

void checkBeforeImport(const std::filesystem::path& path, const Assimp::Importer& importer) {
    routeAssimpLogOnce();
    const std::string source = path.string();
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) throw Error(source, std::nullopt, "mesh file does not exist");
    if (!importer.IsExtensionSupported(path.extension().string()))
        throw Error(source, std::nullopt,
                    "unsupported mesh format '" + path.extension().string() + "' (use OBJ, PLY or glTF 2.0)");

    if (path.extension() == ".ply" || path.extension() == ".PLY") checkPlyHeader(path);
    if (hasExtension(path, ".gltf")) checkGltfBuffers(path);
    if (hasExtension(path, ".obj")) checkObjMaterialLibraries(path);
    // Where several readers list the extension (.glb: glTF 1 and 2), assimp takes one only if it
    // recognises the content, else it offers the content to every reader. So a .glb holding PLY text
    // reached the PLY reader past checkPlyHeader above, and assimp hung on it (fuzz finding 10). Our
    // checks above follow the extension, so a reader of that extension must claim such a file first.
    if (!extensionReaderRecognises(importer, path))
        throw Error(source, std::nullopt,
                    "not a readable " + path.extension().string() + " mesh (assimp's " + path.extension().string() +
                        " reader does not recognise the content)");
}

LoadedModel loadModel(const std::filesystem::path& path) {
    const std::string source = path.string();
    Assimp::Importer importer;
    importer.SetPropertyFloat(AI_CONFIG_PP_GSN_MAX_SMOOTHING_ANGLE, kCreaseAngleDegrees);
    checkBeforeImport(path, importer);
    // Debian's assimp 5.2.5 PLY importer flags triangle meshes as TRIANGLE|POLYGON; with that,
    // SortByPType crashes (SIGBUS) and Triangulate hits an ai_assert that aborts (no handler can
    // be installed). So: no SortByPType (points and lines are skipped below), and Triangulate
    // only when a face really has more than three corners.
    const aiScene* scene = importer.ReadFile(source, aiProcess_PreTransformVertices | aiProcess_ValidateDataStructure);
    if (scene == nullptr) // assimp's words ("aiScene::mNumMeshes is 0") follow ours
        throw Error(source, std::nullopt,
                    "not a readable " + path.extension().string() +
                        " mesh (no triangles could be read; assimp: " + importer.GetErrorString() + ")");
    if ((scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) != 0 || scene->mNumMeshes == 0)
        throw Error(source, std::nullopt, "file contains no triangle meshes");

    bool hasPolygons = false;
    for (unsigned m = 0; m < scene->mNumMeshes; ++m)
        for (unsigned f = 0; f < scene->mMeshes[m]->mNumFaces && !hasPolygons; ++f)
            hasPolygons = scene->mMeshes[m]->mFaces[f].mNumIndices > 3;
    if (hasPolygons) {
        scene = importer.ApplyPostProcessing(aiProcess_Triangulate);
        if (scene == nullptr)
            throw Error(source, std::nullopt, std::string("cannot triangulate: ") + importer.GetErrorString());
    }
    std::vector<bool> hadNormals(scene->mNumMeshes);
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) hadNormals[m] = scene->mMeshes[m]->HasNormals();
    // The importer created the scene (non-const); assimp's public API has no step for this repair.
    std::size_t duplicateTriangles = 0;
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
        aiMesh& mesh = *const_cast<aiMesh*>(scene->mMeshes[m]);
        duplicateTriangles += removeDuplicateTriangles(mesh);
        unshareVertices(mesh);
    }
    scene = importer.ApplyPostProcessing(aiProcess_GenSmoothNormals | aiProcess_JoinIdenticalVertices);
    if (scene == nullptr)
        throw Error(source, std::nullopt, std::string("cannot process mesh: ") + importer.GetErrorString());

    LoadedModel model;
    model.path = path;
    model.report.droppedDuplicateTriangles = duplicateTriangles;
    const std::filesystem::path folder = path.parent_path();
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
        const aiMesh& in = *scene->mMeshes[m];
        MeshPart part;
        part.name = in.mName.C_Str();
        const std::string where =
            source + " (mesh " + std::to_string(m) + (part.name.empty() ? "" : " '" + part.name + "'") + ")";
        TriangleMesh& mesh = part.mesh;
        mesh.positions.resize(in.mNumVertices);
        mesh.normals.resize(in.mNumVertices);
        for (unsigned v = 0; v < in.mNumVertices; ++v) {
            if (!finite(in.mVertices[v]))
                throw Error(where, std::nullopt, "vertex " + std::to_string(v) + " has a non-finite position");
            mesh.positions[v] = {in.mVertices[v].x, in.mVertices[v].y, in.mVertices[v].z};
            const aiVector3D n = in.HasNormals() ? in.mNormals[v] : aiVector3D(0.0f, 0.0f, 0.0f);
            if (hadNormals[m] && !finite(n))
                throw Error(where, std::nullopt,
                            "vertex " + std::to_string(v) + " has a non-finite normal in the file");
            mesh.normals[v] = {n.x, n.y, n.z};
        }
        if (in.HasTextureCoords(0)) {
            mesh.texcoords.resize(in.mNumVertices);
            for (unsigned v = 0; v < in.mNumVertices; ++v) {
                const aiVector3D t = in.mTextureCoords[0][v];
                if (!finite(t))
                    throw Error(where, std::nullopt,
                                "vertex " + std::to_string(v) + " has non-finite texture coordinates");
                mesh.texcoords[v] = {t.x, t.y};
            }
        }
        mesh.indices.reserve(std::size_t(in.mNumFaces) * 3);
        for (unsigned f = 0; f < in.mNumFaces; ++f) {
            const aiFace& face = in.mFaces[f];
            if (face.mNumIndices != 3) continue; // points/lines left in a mixed mesh
            for (unsigned k = 0; k < 3; ++k) {
                if (face.mIndices[k] >= in.mNumVertices)
                    throw Error(where, std::nullopt,
                                "triangle " + std::to_string(f) + " refers to vertex " +
                                    std::to_string(face.mIndices[k]) + " of " + std::to_string(in.mNumVertices));
                mesh.indices.push_back(face.mIndices[k]);
            }
        }
        const DegenerateRepair repair = removeDegenerateTriangles(mesh);
        model.report.droppedDegenerateTriangles += repair.droppedTriangles;
        model.report.removedUnusedVertices += repair.removedVertices;
        if (mesh.indices.empty()) continue;

        if (!hadNormals[m]) ++model.report.partsWithGeneratedNormals;
        for (glm::vec3& n : mesh.normals) {
            const float length = glm::length(n);
            if (std::isfinite(length) && length > 0.0f) {
                n /= length;
            } else if (!hadNormals[m]) {
                n = {0.0f, 0.0f, 1.0f};
                ++model.report.repairedNormals;
            } else {
                throw Error(where, std::nullopt, "the file stores a zero-length normal");
            }
        }
        if (in.mMaterialIndex < scene->mNumMaterials)
            part.material = convertMaterial(*scene->mMaterials[in.mMaterialIndex], folder, part.materialName,
                                            part.emission, source);
        mesh.validate(where);
        const OpenBoundaries open = findOpenBoundaries(mesh);
        model.report.boundaryEdges += open.edges;
        model.report.boundaryLoops += open.loops;
        model.parts.push_back(std::move(part));
    }
    if (model.parts.empty()) throw Error(source, std::nullopt, "file contains no non-degenerate triangles");

    const MeshLoadReport& r = model.report;
    if (r.droppedDegenerateTriangles > 0 || r.droppedDuplicateTriangles > 0 || r.partsWithGeneratedNormals > 0)
        log::info(source + ": dropped " + std::to_string(r.droppedDegenerateTriangles) + " degenerate and " +
                  std::to_string(r.droppedDuplicateTriangles) + " duplicate triangles, generated normals for " +
                  std::to_string(r.partsWithGeneratedNormals) + " part(s)");
    return model;
}

OpenBoundaries findOpenBoundaries(const TriangleMesh& mesh) {
    const CornerIds ids = cornerIdsByPosition(mesh.positions.size(), [&](std::size_t i) {
        const glm::vec3& p = mesh.positions[i];
        return std::array<float, 3>{p.x, p.y, p.z};
    });
    const std::vector<std::uint32_t>& corner = ids.id;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
    edges.reserve(mesh.indices.size());
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3)
        for (std::size_t k = 0; k < 3; ++k) {
            const std::uint32_t a = corner[mesh.indices[t + k]], b = corner[mesh.indices[t + (k + 1) % 3]];
            if (a != b) edges.emplace_back(std::min(a, b), std::max(a, b));
        }
    std::sort(edges.begin(), edges.end());
    // Union-find over the corners of boundary edges: one root per loop.
    std::vector<std::uint32_t> parent(ids.count);
    for (std::uint32_t i = 0; i < parent.size(); ++i) parent[i] = i;
    const auto find = [&](std::uint32_t x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
    };
    std::vector<bool> onBoundary(parent.size(), false);
    OpenBoundaries result;
    for (std::size_t k = 0; k < edges.size();) {
        std::size_t next = k + 1;
        while (next < edges.size() && edges[next] == edges[k]) ++next;
        if (next - k == 1) {
            ++result.edges;
            const auto [a, b] = edges[k];
            onBoundary[a] = onBoundary[b] = true;
            parent[find(a)] = find(b);
        }
        k = next;
    }
    for (std::uint32_t i = 0; i < parent.size(); ++i)
        if (onBoundary[i] && find(i) == i) ++result.loops;
    return result;
}

std::string openBoundaryWarning(const std::string& meshFile, const MeshLoadReport& report) {
    if (report.boundaryEdges == 0) return {};
    return meshFile + ": the mesh is open (" + std::to_string(report.boundaryLoops) + " hole(s), " +
           std::to_string(report.boundaryEdges) +
           " boundary edges): where the camera sees the object's inside through a hole, the GI gives it no "
           "indirect light (a nearly closed object's inside is lit only through its holes), so a hole shows "
           "as a dark spot; close the holes (a watertight remesh) if the object should look solid";
}

} // namespace lightskin::render
