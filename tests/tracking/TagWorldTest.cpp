// World config: valid single tags and bundles parse to the poses written; every kind of bad input
// is an Error that names the file and the key.
#include "TestPaths.h"

#include <lightskin/core/Error.h>
#include <lightskin/tracking/TagWorld.h>

#include <gtest/gtest.h>

#include <fstream>

namespace lightskin::tracking {
namespace {

// Returns the error's cause (and checks it names `source`), or fails.
std::string errorOf(const std::string& json, const std::string& source = "world.json") {
    try {
        TagWorld::fromJson(json, source);
    } catch (const Error& error) {
        EXPECT_EQ(error.source(), source);
        return error.cause();
    }
    ADD_FAILURE() << "no error for: " << json;
    return {};
}

TEST(TagWorldTest, SingleTag) {
    const TagWorld world = TagWorld::fromJson(R"({"tag": {"id": 3, "size": 0.16}})", "w.json");
    EXPECT_EQ(world.family(), "tag36h11");
    ASSERT_EQ(world.tags().size(), 1u);
    EXPECT_EQ(world.tags()[0].id, 3);
    EXPECT_DOUBLE_EQ(world.tags()[0].sizeMetres, 0.16);
    EXPECT_DOUBLE_EQ(Pose::translationDistance(world.tags()[0].world_T_tag, Pose()), 0.0);
    EXPECT_FALSE(world.isBundle());
    EXPECT_NE(world.find(3), nullptr);
    EXPECT_EQ(world.find(4), nullptr);
}

TEST(TagWorldTest, BundleWithPosesAndFamily) {
    // Tag 9 turned 90 degrees about z: quaternion (cos 45, 0, 0, sin 45).
    const TagWorld world = TagWorld::fromJson(R"({
        "family": "tag25h9",
        "tags": [
          {"id": 9, "size": 0.05, "position": [0.3, -0.1, 0.0], "orientation": [0.7071067811865476, 0, 0, 0.7071067811865476]},
          {"id": 2, "size": 0.1}
        ]})",
                                              "bundle.json");
    EXPECT_EQ(world.family(), "tag25h9");
    ASSERT_EQ(world.tags().size(), 2u);
    EXPECT_TRUE(world.isBundle());
    EXPECT_EQ(world.tags()[0].id, 2); // sorted by id
    const WorldTag* nine = world.find(9);
    ASSERT_NE(nine, nullptr);
    // The tag's x axis points along the world's y axis.
    const glm::dvec3 x = nine->world_T_tag.transformDirection({1.0, 0.0, 0.0});
    EXPECT_NEAR(x.x, 0.0, 1e-12);
    EXPECT_NEAR(x.y, 1.0, 1e-12);
    EXPECT_NEAR(nine->world_T_tag.translation().x, 0.3, 1e-12);
    EXPECT_NEAR(nine->world_T_tag.translation().y, -0.1, 1e-12);
}

TEST(TagWorldTest, LoadReadsAFileAndNamesMissingOnes) {
    const auto folder = test::scratchDir("tag_world_test");
    const auto path = folder / "world.json";
    std::ofstream(path) << R"({"tag": {"id": 0, "size": 0.2}})";
    EXPECT_EQ(TagWorld::load(path).tags().at(0).id, 0);
    try {
        TagWorld::load(folder / "missing.json");
        FAIL();
    } catch (const Error& error) {
        EXPECT_EQ(error.source(), (folder / "missing.json").string());
    }
}

TEST(TagWorldTest, DuplicateIdsNameBothEntries) {
    const std::string cause =
        errorOf(R"({"tags": [{"id": 1, "size": 0.1}, {"id": 4, "size": 0.1}, {"id": 1, "size": 0.2}]})");
    EXPECT_EQ(cause.rfind("/tags/2/id: duplicate tag id 1", 0), 0u) << cause;
    EXPECT_NE(cause.find("/tags/0"), std::string::npos) << cause;
}

TEST(TagWorldTest, BadSizesNameTheKey) {
    for (const char* size : {"0", "-0.1", "160", "0.0001", "\"big\"", "null"}) {
        const std::string cause =
            errorOf(std::string(R"({"tags": [{"id": 1, "size": 0.1}, {"id": 2, "size": )") + size + "}]}");
        EXPECT_EQ(cause.rfind("/tags/1/size: expected ", 0), 0u) << size << ": " << cause;
    }
    // The value as written, not std::to_string's "160.000000".
    EXPECT_EQ(errorOf(R"({"tag": {"id": 1, "size": 160}})"),
              "/tag/size: expected the black-border edge length in metres, between 0.001 and 100, got 160");
    EXPECT_EQ(errorOf(R"({"tag": {"id": 1}})").rfind("/tag/size: missing", 0), 0u);
}

// The scene file's format (render/src/Scene.cpp): "<pointer>: expected ..., got ..." or "<pointer>:
// unknown key; expected one of: ...", so a tag world inside a scene reads like the rest of the scene.
TEST(TagWorldTest, MalformedJsonAndWrongStructure) {
    EXPECT_EQ(errorOf(R"({"tag": {"id": 1, "size": 0.1})").rfind("not valid JSON", 0), 0u);
    EXPECT_EQ(errorOf("").rfind("not valid JSON", 0), 0u);
    EXPECT_EQ(errorOf("[1, 2]"), R"(/: expected an object with "tag" or "tags", got [1,2])");
    EXPECT_EQ(errorOf("{}").rfind("/: expected exactly one of", 0), 0u);
    EXPECT_EQ(errorOf(R"({"tag": {"id": 1, "size": 0.1}, "tags": []})").rfind("/tags: expected exactly one of", 0), 0u);
    EXPECT_EQ(errorOf(R"({"tags": []})"), "/tags: expected at least one tag");
    EXPECT_EQ(errorOf(R"({"tags": {"id": 1}})"), R"(/tags: expected an array of tags, got {"id":1})");
    EXPECT_EQ(errorOf(R"({"tags": [{"id": 1.5, "size": 0.1}]})"), "/tags/0/id: expected an integer tag id, got 1.5");
    EXPECT_EQ(errorOf(R"({"tags": [{"id": 1, "size": 0.1, "positon": [0, 0, 0]}]})"),
              "/tags/0/positon: unknown key; expected one of: id, size, position, orientation");
    EXPECT_EQ(errorOf(R"({"tags": [{"id": 1, "size": 0.1, "position": [0, 0]}]})"),
              "/tags/0/position: expected an array of 3 numbers, got [0,0]");
    EXPECT_EQ(errorOf(R"({"tags": [{"id": 1, "size": 0.1, "orientation": [1, 1, 0, 0]}]})")
                  .rfind("/tags/0/orientation: expected a unit quaternion", 0),
              0u);
    EXPECT_EQ(
        errorOf(R"({"tag": {"id": 1, "size": 0.1, "position": [0, 0, 0]}})").rfind("/tag/position: unknown key", 0),
        0u);
    EXPECT_EQ(errorOf(R"({"family": 7, "tag": {"id": 1, "size": 0.1}})"), "/family: expected a tag family name, got 7");
    EXPECT_EQ(errorOf(R"({"family": "tag99", "tag": {"id": 1, "size": 0.1}})").rfind("/family: ", 0), 0u);
    EXPECT_EQ(errorOf(R"({"tag": {"id": 587, "size": 0.1}})"), // tag36h11 has 0..586
              "/tag/id: expected an id of tag36h11 (0..586), got 587");
    EXPECT_EQ(errorOf(R"({"tagz": 1})"), "/tagz: unknown key; expected one of: family, tag, tags");
}

// Inside a scene the world's keys are prefixed with where it sits ("/tracking"); the source stays the file.
TEST(TagWorldTest, AWorldInsideAFileNamesItsFullPointer) {
    try {
        (void)TagWorld::fromJson(R"({"tags": [{"id": 1, "size": -3}]})", "scene.json", "/tracking");
        FAIL();
    } catch (const Error& error) {
        EXPECT_EQ(std::string(error.what()),
                  "scene.json: /tracking/tags/0/size: expected the black-border edge length in metres, between 0.001 "
                  "and 100, got -3");
    }
    try {
        (void)TagWorld::fromJson("[]", "scene.json", "/tracking");
        FAIL();
    } catch (const Error& error) {
        EXPECT_EQ(error.cause(), R"(/tracking: expected an object with "tag" or "tags", got [])");
    }
}

} // namespace
} // namespace lightskin::tracking
