#include <lightskin/core/Error.h>
#include <lightskin/roommodel/RoomMemory.h>

#include <gtest/gtest.h>

#include <string>

namespace lightskin::roommodel {
namespace {

std::string causeOf(const std::string& json) {
    try {
        roomMemorySettingsFromJson(json, "orbit.json", "/roomModel");
    } catch (const Error& error) {
        EXPECT_EQ(error.source(), "orbit.json");
        return error.cause();
    }
    return "";
}

TEST(RoomMemoryJson, ReadsEveryKey) {
    const RoomMemorySettings s = roomMemorySettingsFromJson(
        R"({"bounds": {"min": [-1, -2, -0.5], "max": [3, 2, 2.5]}, "voxelSizeMetres": 0.05, "truncationMetres": 0.15,
            "maxWeight": 20, "maxDepthMetres": 3.5, "memoryBudgetMB": 8, "processingWidth": 640,
            "depthTracking": {"enabled": false, "blendFrames": 4, "maxFrames": 60, "trackingWidth": 320,
                              "maxCorrectionMetres": 0.02, "maxCorrectionDegrees": 2, "minValidFraction": 0.3}})",
        "orbit.json", "/roomModel");
    EXPECT_EQ(s.model.boundsMin, glm::dvec3(-1.0, -2.0, -0.5));
    EXPECT_EQ(s.model.boundsMax, glm::dvec3(3.0, 2.0, 2.5));
    EXPECT_EQ(s.model.voxelSizeMetres, 0.05);
    EXPECT_EQ(s.model.truncationMetres, 0.15);
    EXPECT_EQ(s.model.maxWeight, 20);
    EXPECT_EQ(s.model.maxDepthMetres, 3.5);
    EXPECT_EQ(s.model.memoryBudgetMB, 8.0);
    EXPECT_EQ(s.processingWidth, 640);
    EXPECT_FALSE(s.depthTracking.enabled);
    EXPECT_EQ(s.depthTracking.blendFrames, 4);
    EXPECT_EQ(s.depthTracking.maxFrames, 60);
    EXPECT_EQ(s.depthTracking.trackingWidth, 320);
    EXPECT_EQ(s.depthTracking.maxCorrectionMetres, 0.02);
    EXPECT_EQ(s.depthTracking.maxCorrectionDegrees, 2.0);
    EXPECT_EQ(s.depthTracking.minValidFraction, 0.3);
}

TEST(RoomMemoryJson, ErrorsNameTheKey) {
    EXPECT_EQ(causeOf("{}"), ""); // every key has a default
    EXPECT_EQ(causeOf(R"({"voxelSize": 0.02})").rfind("/roomModel/voxelSize: unknown key; expected one of: ", 0), 0u);
    EXPECT_EQ(causeOf(R"({"voxelSizeMetres": "fine"})"), "/roomModel/voxelSizeMetres: expected a number, got \"fine\"");
    EXPECT_EQ(causeOf(R"({"bounds": {"min": [0, 0]}})"),
              "/roomModel/bounds/min: expected [x, y, z] in metres, got [0,0]");
    EXPECT_EQ(causeOf(R"({"depthTracking": {"blendFrames": 2.5}})"),
              "/roomModel/depthTracking/blendFrames: expected an integer, got 2.5");
    EXPECT_EQ(causeOf(R"({"depthTracking": {"blendFrames": 0}})"),
              "/roomModel/depthTracking/blendFrames: expected an integer >= 1");
    EXPECT_EQ(causeOf(R"({"maxWeight": 300})"),
              "/roomModel/maxWeight: expected an integer in [1, 255] (8-bit weights), got 300");
    EXPECT_EQ(causeOf(R"({"memoryBudgetMB": 1})").rfind("/roomModel/memoryBudgetMB: the box needs ", 0), 0u);
    EXPECT_EQ(causeOf("[1]"), "/roomModel: expected an object, got [1]");
}

} // namespace
} // namespace lightskin::roommodel
