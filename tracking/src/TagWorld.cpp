#include <lightskin/core/Error.h>
#include <lightskin/core/JsonError.h>
#include <lightskin/tracking/TagFamily.h>
#include <lightskin/tracking/TagWorld.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

namespace lightskin::tracking {

namespace {
using Json = nlohmann::json;

/// Errors read like the scene file's (render/src/Scene.cpp): "<file>: <JSON pointer>: expected ...,
/// got ...". `key` is the pointer within the tag world; fromJson prefixes where the world sits in its
/// file (a scene's "/tracking").
[[noreturn]] void fail(const std::string& source, const std::string& key, const std::string& cause) {
    throw Error(source, std::nullopt, (key.empty() ? std::string("/") : key) + ": " + cause);
}

/// A number as a user writes it ("160", "1e-05"), not std::to_string's "160.000000".
std::string shortNumber(double value) {
    std::ostringstream text;
    text << value;
    return text.str();
}

/// A JSON value for a message, cut like the scene file's.
std::string shown(const Json& value) {
    std::string text = value.dump();
    if (text.size() > 60) text = text.substr(0, 57) + "...";
    return text;
}

double readNumber(const Json& object, const std::string& name, const std::string& key, const std::string& source) {
    const auto it = object.find(name);
    if (it == object.end()) fail(source, key, "missing (a number)");
    if (!it->is_number()) fail(source, key, "expected a number, got " + shown(*it));
    return it->get<double>();
}

int readId(const Json& object, const std::string& key, const std::string& source) {
    const auto it = object.find("id");
    if (it == object.end()) fail(source, key, "missing (an integer tag id)");
    if (!it->is_number_integer()) fail(source, key, "expected an integer tag id, got " + shown(*it));
    const auto value = it->get<std::int64_t>();
    if (value < 0 || value > 1000000) fail(source, key, "expected a tag id >= 0, got " + shown(*it));
    return static_cast<int>(value);
}

std::vector<double> readArray(const Json& object, const std::string& name, std::size_t size, const std::string& key,
                              const std::string& source) {
    const Json& value = object.at(name);
    if (!value.is_array() || value.size() != size)
        fail(source, key, "expected an array of " + std::to_string(size) + " numbers, got " + shown(value));
    std::vector<double> numbers;
    for (const Json& element : value) {
        if (!element.is_number() || !std::isfinite(element.get<double>()))
            fail(source, key, "expected finite numbers, got " + shown(value));
        numbers.push_back(element.get<double>());
    }
    return numbers;
}

WorldTag readTag(const Json& object, const std::string& key, const std::string& source, bool withPose) {
    if (!object.is_object()) fail(source, key, "expected an object with \"id\" and \"size\", got " + shown(object));
    for (const auto& item : object.items()) {
        const std::string& name = item.key(); // not a structured binding: clang 15 cannot capture one
        static const char* known[] = {"id", "size", "position", "orientation"};
        const bool isKnown = std::any_of(std::begin(known), std::end(known), [&](const char* k) { return name == k; });
        if (!isKnown || (!withPose && (name == "position" || name == "orientation")))
            fail(source, key + "/" + name,
                 withPose ? "unknown key; expected one of: id, size, position, orientation"
                          : "unknown key; expected one of: id, size (a single tag sits at the origin)");
    }
    WorldTag tag;
    tag.id = readId(object, key + "/id", source);
    tag.sizeMetres = readNumber(object, "size", key + "/size", source);
    glm::dvec3 position(0.0);
    glm::dquat orientation(1.0, 0.0, 0.0, 0.0);
    if (object.contains("position")) {
        const auto p = readArray(object, "position", 3, key + "/position", source);
        position = {p[0], p[1], p[2]};
    }
    if (object.contains("orientation")) {
        const auto q = readArray(object, "orientation", 4, key + "/orientation", source);
        orientation = glm::dquat(q[0], q[1], q[2], q[3]);
        const double norm = glm::length(orientation);
        if (std::abs(norm - 1.0) > 1e-3)
            fail(source, key + "/orientation",
                 "expected a unit quaternion [w, x, y, z], its norm is " + std::to_string(norm));
        orientation = glm::normalize(orientation);
    }
    tag.world_T_tag = Pose(orientation, position);
    return tag;
}
} // namespace

TagWorld TagWorld::bundle(std::vector<WorldTag> tags, const std::string& family, const std::string& sourceName) {
    if (tags.empty()) fail(sourceName, "/tags", "expected at least one tag");
    int familySize = 0;
    try {
        familySize = tagFamilySize(family);
    } catch (const Error& error) {
        fail(sourceName, "/family", error.cause());
    }
    for (std::size_t i = 0; i < tags.size(); ++i) {
        const std::string key = "/tags/" + std::to_string(i);
        const WorldTag& tag = tags[i];
        if (tag.id < 0 || tag.id >= familySize)
            fail(sourceName, key + "/id",
                 "expected an id of " + family + " (0.." + std::to_string(familySize - 1) + "), got " +
                     std::to_string(tag.id));
        // 1 mm .. 100 m: anything else is a unit mistake (millimetres or centimetres given as metres).
        if (!std::isfinite(tag.sizeMetres) || tag.sizeMetres < 0.001 || tag.sizeMetres > 100.0)
            fail(sourceName, key + "/size",
                 "expected the black-border edge length in metres, between 0.001 and 100, got " +
                     shortNumber(tag.sizeMetres));
        for (std::size_t j = 0; j < i; ++j) {
            if (tags[j].id == tag.id)
                fail(sourceName, key + "/id",
                     "duplicate tag id " + std::to_string(tag.id) + " (also /tags/" + std::to_string(j) + ")");
        }
    }
    TagWorld world;
    world.family_ = family;
    world.tags_ = std::move(tags);
    std::sort(world.tags_.begin(), world.tags_.end(), [](const WorldTag& a, const WorldTag& b) { return a.id < b.id; });
    return world;
}

TagWorld TagWorld::singleTag(int id, double sizeMetres, const std::string& family) {
    WorldTag tag;
    tag.id = id;
    tag.sizeMetres = sizeMetres;
    return bundle({tag}, family, "single tag");
}

TagWorld TagWorld::fromJson(const std::string& text, const std::string& sourceName, const std::string& pointer) {
    try {
        return parse(text, sourceName);
    } catch (const Error& error) {
        // Every cause starts with the key's pointer within the world: prefix where the world sits.
        if (pointer.empty() || !error.cause().starts_with("/")) throw;
        throw Error(sourceName, std::nullopt,
                    pointer + (error.cause().starts_with("/:") ? error.cause().substr(1) : error.cause()));
    }
}

TagWorld TagWorld::parse(const std::string& text, const std::string& sourceName) {
    Json root;
    try {
        root = Json::parse(text);
    } catch (const Json::exception& error) { // parse_error, and out_of_range for a number that overflows
        throw Error(sourceName, std::nullopt, "not valid JSON: " + jsonErrorCause(error.what()));
    }
    if (!root.is_object()) fail(sourceName, "", "expected an object with \"tag\" or \"tags\", got " + shown(root));
    for (const auto& [name, value] : root.items()) {
        if (name != "family" && name != "tag" && name != "tags")
            fail(sourceName, "/" + name, "unknown key; expected one of: family, tag, tags");
    }
    std::string family = defaultTagFamily;
    if (root.contains("family")) {
        if (!root["family"].is_string())
            fail(sourceName, "/family", "expected a tag family name, got " + shown(root["family"]));
        family = root["family"].get<std::string>();
    }
    const bool hasTag = root.contains("tag");
    const bool hasTags = root.contains("tags");
    if (hasTag == hasTags)
        fail(sourceName, hasTag ? "/tags" : "", "expected exactly one of \"tag\" (single tag) or \"tags\" (bundle)");
    std::vector<WorldTag> tags;
    if (hasTag) {
        tags.push_back(readTag(root["tag"], "/tag", sourceName, false));
        try {
            return bundle(std::move(tags), family, sourceName);
        } catch (const Error& error) {
            // Name the single tag's key as written in the file.
            std::string cause = error.cause();
            if (cause.starts_with("/tags/0")) cause = "/tag" + cause.substr(7);
            throw Error(sourceName, std::nullopt, cause);
        }
    }
    const Json& list = root["tags"];
    if (!list.is_array()) fail(sourceName, "/tags", "expected an array of tags, got " + shown(list));
    for (std::size_t i = 0; i < list.size(); ++i)
        tags.push_back(readTag(list[i], "/tags/" + std::to_string(i), sourceName, true));
    return bundle(std::move(tags), family, sourceName);
}

TagWorld TagWorld::load(const std::filesystem::path& path) {
    std::ifstream file(path);
    if (!file) throw Error(path.string(), std::nullopt, "cannot open the tag world config");
    std::ostringstream text;
    text << file.rdbuf();
    return fromJson(text.str(), path.string());
}

const WorldTag* TagWorld::find(int id) const noexcept {
    const auto it =
        std::lower_bound(tags_.begin(), tags_.end(), id, [](const WorldTag& tag, int value) { return tag.id < value; });
    return it != tags_.end() && it->id == id ? &*it : nullptr;
}

} // namespace lightskin::tracking
