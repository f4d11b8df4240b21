#include <lightskin/core/Error.h>
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

[[noreturn]] void fail(const std::string& source, const std::string& key, const std::string& cause) {
    throw Error(source, std::nullopt, key + ": " + cause);
}

double readNumber(const Json& object, const std::string& name, const std::string& key, const std::string& source) {
    const auto it = object.find(name);
    if (it == object.end()) fail(source, key, "missing");
    if (!it->is_number()) fail(source, key, "must be a number, got " + it->dump());
    return it->get<double>();
}

int readId(const Json& object, const std::string& key, const std::string& source) {
    const auto it = object.find("id");
    if (it == object.end()) fail(source, key, "missing");
    if (!it->is_number_integer()) fail(source, key, "must be an integer tag id, got " + it->dump());
    const auto value = it->get<std::int64_t>();
    if (value < 0 || value > 1000000) fail(source, key, "must be a tag id >= 0, got " + it->dump());
    return static_cast<int>(value);
}

std::vector<double> readArray(const Json& object, const std::string& name, std::size_t size, const std::string& key,
                              const std::string& source) {
    const Json& value = object.at(name);
    if (!value.is_array() || value.size() != size)
        fail(source, key, "must be an array of " + std::to_string(size) + " numbers, got " + value.dump());
    std::vector<double> numbers;
    for (const Json& element : value) {
        if (!element.is_number() || !std::isfinite(element.get<double>()))
            fail(source, key, "must contain finite numbers, got " + value.dump());
        numbers.push_back(element.get<double>());
    }
    return numbers;
}

WorldTag readTag(const Json& object, const std::string& key, const std::string& source, bool withPose) {
    if (!object.is_object()) fail(source, key, "must be an object with \"id\" and \"size\", got " + object.dump());
    for (const auto& item : object.items()) {
        const std::string& name = item.key(); // not a structured binding: clang 15 cannot capture one
        static const char* known[] = {"id", "size", "position", "orientation"};
        const bool isKnown = std::any_of(std::begin(known), std::end(known), [&](const char* k) { return name == k; });
        if (!isKnown || (!withPose && (name == "position" || name == "orientation")))
            fail(source, key + "." + name, "unknown key");
    }
    WorldTag tag;
    tag.id = readId(object, key + ".id", source);
    tag.sizeMetres = readNumber(object, "size", key + ".size", source);
    glm::dvec3 position(0.0);
    glm::dquat orientation(1.0, 0.0, 0.0, 0.0);
    if (object.contains("position")) {
        const auto p = readArray(object, "position", 3, key + ".position", source);
        position = {p[0], p[1], p[2]};
    }
    if (object.contains("orientation")) {
        const auto q = readArray(object, "orientation", 4, key + ".orientation", source);
        orientation = glm::dquat(q[0], q[1], q[2], q[3]);
        const double norm = glm::length(orientation);
        if (std::abs(norm - 1.0) > 1e-3)
            fail(source, key + ".orientation",
                 "must be a unit quaternion [w, x, y, z], its norm is " + std::to_string(norm));
        orientation = glm::normalize(orientation);
    }
    tag.world_T_tag = Pose(orientation, position);
    return tag;
}
} // namespace

TagWorld TagWorld::bundle(std::vector<WorldTag> tags, const std::string& family, const std::string& sourceName) {
    if (tags.empty()) fail(sourceName, "tags", "the world needs at least one tag");
    int familySize = 0;
    try {
        familySize = tagFamilySize(family);
    } catch (const Error& error) {
        fail(sourceName, "family", error.cause());
    }
    for (std::size_t i = 0; i < tags.size(); ++i) {
        const std::string key = "tags[" + std::to_string(i) + "]";
        const WorldTag& tag = tags[i];
        if (tag.id < 0 || tag.id >= familySize)
            fail(sourceName, key + ".id",
                 "id " + std::to_string(tag.id) + " is not in " + family + " (0.." + std::to_string(familySize - 1) +
                     ")");
        // 1 mm .. 100 m: anything else is a unit mistake (millimetres or centimetres given as metres).
        if (!std::isfinite(tag.sizeMetres) || tag.sizeMetres < 0.001 || tag.sizeMetres > 100.0)
            fail(sourceName, key + ".size",
                 "must be the black-border edge length in metres, between 0.001 and 100, got " +
                     std::to_string(tag.sizeMetres));
        for (std::size_t j = 0; j < i; ++j) {
            if (tags[j].id == tag.id)
                fail(sourceName, key + ".id",
                     "duplicate tag id " + std::to_string(tag.id) + " (also tags[" + std::to_string(j) + "])");
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

TagWorld TagWorld::fromJson(const std::string& text, const std::string& sourceName) {
    Json root;
    try {
        root = Json::parse(text);
    } catch (const Json::exception& error) { // parse_error, and out_of_range for a number that overflows
        fail(sourceName, "(json)", std::string("malformed JSON: ") + error.what());
    }
    if (!root.is_object()) fail(sourceName, "(root)", "must be a JSON object with \"tag\" or \"tags\"");
    for (const auto& [name, value] : root.items()) {
        if (name != "family" && name != "tag" && name != "tags") fail(sourceName, name, "unknown key");
    }
    std::string family = defaultTagFamily;
    if (root.contains("family")) {
        if (!root["family"].is_string()) fail(sourceName, "family", "must be a string, got " + root["family"].dump());
        family = root["family"].get<std::string>();
    }
    const bool hasTag = root.contains("tag");
    const bool hasTags = root.contains("tags");
    if (hasTag == hasTags)
        fail(sourceName, "tag/tags", "give exactly one of \"tag\" (single tag) or \"tags\" (bundle)");
    std::vector<WorldTag> tags;
    if (hasTag) {
        tags.push_back(readTag(root["tag"], "tag", sourceName, false));
        try {
            return bundle(std::move(tags), family, sourceName);
        } catch (const Error& error) {
            // Name the single tag's key as written in the file.
            std::string cause = error.cause();
            if (cause.rfind("tags[0]", 0) == 0) cause = "tag" + cause.substr(7);
            throw Error(sourceName, std::nullopt, cause);
        }
    }
    const Json& list = root["tags"];
    if (!list.is_array()) fail(sourceName, "tags", "must be an array of tags, got " + list.dump());
    for (std::size_t i = 0; i < list.size(); ++i)
        tags.push_back(readTag(list[i], "tags[" + std::to_string(i) + "]", sourceName, true));
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
