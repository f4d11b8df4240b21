#pragma once
// The world frame, defined by AprilTags: one tag, or a bundle of tags with known poses.
//
// Config file (JSON), all lengths in metres:
//   single tag:  { "family": "tag36h11", "tag": { "id": 3, "size": 0.16 } }
//                The world frame is that tag's frame (TagFamily.h: origin at the tag centre, x right
//                and y up along the printed tag, z out of the printed surface).
//   tag bundle:  { "family": "tag36h11",
//                  "tags": [ { "id": 0, "size": 0.16, "position": [0, 0, 0], "orientation": [1, 0, 0, 0] },
//                            { "id": 1, "size": 0.08, "position": [0.3, 0, 0] } ] }
//                position = the tag centre in the world frame; orientation = world_R_tag as a unit
//                quaternion [w, x, y, z] (default identity: the tag lies in the world's z = 0 plane,
//                facing +z). "family" is optional (default tag36h11).
// size = edge length of the tag's black-border square (AprilTag's convention), not the full print.

#include <lightskin/core/Pose.h>

#include <filesystem>
#include <string>
#include <vector>

namespace lightskin::tracking {

struct WorldTag {
    int id = -1;
    /// Black-border edge length, metres (> 0).
    double sizeMetres = 0.0;
    /// Maps tag-frame points to world points.
    Pose world_T_tag;
};

class TagWorld {
public:
    /// One tag at the world origin (world frame = tag frame). Throws lightskin::Error on a bad id/size.
    static TagWorld singleTag(int id, double sizeMetres, const std::string& family = "tag36h11");
    /// Several tags; throws lightskin::Error naming `/tags/<i>/<key>` on duplicate ids, sizes that are
    /// not positive and finite, ids outside the family, or an empty list.
    static TagWorld bundle(std::vector<WorldTag> tags, const std::string& family = "tag36h11",
                           const std::string& sourceName = "tag bundle");
    /// Parses the JSON described above. Errors read like the scene file's: source `sourceName` (the
    /// file), cause "<pointer><key>: expected ..., got ..." where <key> is the JSON pointer within the
    /// world (e.g. "/tags/2/size") and `pointer` where the world sits in its file (a scene's
    /// "/tracking"; empty for a tag-world file), for malformed JSON, missing or mistyped keys and bad values.
    static TagWorld fromJson(const std::string& text, const std::string& sourceName, const std::string& pointer = {});
    /// Reads and parses a config file; throws lightskin::Error naming the file.
    static TagWorld load(const std::filesystem::path& path);

    const std::string& family() const noexcept { return family_; }
    /// Sorted by id.
    const std::vector<WorldTag>& tags() const noexcept { return tags_; }
    /// The tag with this id, or nullptr when the world does not contain it.
    const WorldTag* find(int id) const noexcept;
    bool isBundle() const noexcept { return tags_.size() > 1; }

private:
    TagWorld() = default;
    static TagWorld parse(const std::string& text, const std::string& sourceName);
    std::string family_;
    std::vector<WorldTag> tags_;
};

} // namespace lightskin::tracking
