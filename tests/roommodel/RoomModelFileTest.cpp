#include "SyntheticRoom.h"
#include "TestPaths.h"

#include <lightskin/core/Error.h>
#include <lightskin/roommodel/RoomMemory.h>
#include <lightskin/roommodel/RoomModelFile.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

namespace lightskin::roommodel {
namespace {

namespace fs = std::filesystem;
using test::lookAt;
using test::renderRoomDepth;
using test::SyntheticRoom;
using test::syntheticRoomIntrinsics;

RoomModelSettings roomSettings(const SyntheticRoom& room) {
    RoomModelSettings s;
    s.voxelSizeMetres = 0.04;
    s.truncationMetres = 0.12;
    s.boundsMin = room.roomMin - 0.15; // a truncation distance beyond the walls
    s.boundsMax = room.roomMax + 0.15;
    return s;
}

const glm::dvec3 kTarget(2.0, 1.75, 0.6);

/// A model fused from five views around the table.
RoomModel fusedRoom(const SyntheticRoom& room) {
    RoomModel model = RoomModel::create(roomSettings(room));
    const CameraIntrinsics k = syntheticRoomIntrinsics();
    for (const glm::dvec3 position : {glm::dvec3(0.6, 0.5, 1.6), glm::dvec3(1.3, 0.4, 1.65), glm::dvec3(2.0, 0.3, 1.7),
                                      glm::dvec3(2.7, 0.4, 1.65), glm::dvec3(3.4, 0.5, 1.6)}) {
        const Pose pose = lookAt(position, kTarget);
        model.integrate(renderRoomDepth(room, k, pose), k, pose);
    }
    return model;
}

std::string readBytes(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void writeBytes(const fs::path& file, const std::string& bytes) {
    std::ofstream(file, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(bytes.size()));
}

/// The error's text when `load` throws lightskin::Error, else "".
template <typename F>
std::string errorOf(F&& load) {
    try {
        load();
    } catch (const Error& error) {
        return error.what();
    }
    return "";
}

TEST(RoomModelFile, ViewsAreSpacedAndBounded) {
    const SyntheticRoom room;
    RoomModel model = RoomModel::create(roomSettings(room));
    const CameraIntrinsics k = syntheticRoomIntrinsics();
    const Pose a = lookAt({0.6, 0.5, 1.6}, kTarget);
    const cv::Mat depth = renderRoomDepth(room, k, a);
    model.integrate(depth, k, a);
    model.integrate(depth, k, Pose(a.rotation(), a.translation() + glm::dvec3(0.1, 0.0, 0.0))); // 0.1 m: the same view
    EXPECT_EQ(model.views().size(), 1u);
    model.integrate(depth, k, Pose(a.rotation(), a.translation() + glm::dvec3(0.3, 0.0, 0.0))); // 0.3 m: a new one
    EXPECT_EQ(model.views().size(), 2u);
    model.reset();
    EXPECT_TRUE(model.views().empty());
}

// The loaded model renders what the saved one rendered. From a view it was saved with, the difference is the
// round trip's: the depth quantum (0.5 mm) and the re-fusion of a quantised plane (the TSDF's own 8-bit quantum,
// truncation / 127 = 0.94 mm), so the median within 2 mm; near edges the re-fused field may move a surface by up
// to half a voxel (20 mm, as in RoomModelTest): 95 % within that. From a novel view between the saved ones the
// loaded model must still match the room's true depth as well as the fused one does (same bounds).
TEST(RoomModelFile, ALoadedModelRendersTheSavedSurfaces) {
    const SyntheticRoom room;
    const RoomModel saved = fusedRoom(room);
    ASSERT_GE(saved.views().size(), 4u);
    const fs::path file = test::scratchDir("room_model_file_round_trip") / "room.lsroom";
    saveRoomModel(saved, file);
    ASSERT_TRUE(isRoomModelFile(file));

    RoomModel loaded = RoomModel::create(roomSettings(room));
    loadRoomModelInto(loaded, file);
    EXPECT_EQ(loaded.views().size(), saved.views().size());
    const CameraIntrinsics k = syntheticRoomIntrinsics();
    for (const Pose& pose : {saved.views()[1].world_T_camera, lookAt({1.65, 0.35, 1.68}, kTarget)}) {
        cv::Mat before, after;
        saved.renderDepthInto(pose, k, before);
        loaded.renderDepthInto(pose, k, after);
        const cv::Mat truth = renderRoomDepth(room, k, pose);
        std::vector<double> errors;
        int savedPixels = 0;
        for (int v = 0; v < truth.rows; ++v)
            for (int u = 0; u < truth.cols; ++u) {
                if (before.at<float>(v, u) <= 0.0f) continue;
                ++savedPixels;
                if (after.at<float>(v, u) > 0.0f)
                    errors.push_back(std::abs(double(after.at<float>(v, u)) - double(before.at<float>(v, u))));
            }
        // The loaded model covers what the saved one did, but for surfaces that only the fused frames' grazing rays
        // reached (the table's edges, the far corners): a few % of the pixels, bound 3 %.
        ASSERT_GT(errors.size(), std::size_t(0.97 * savedPixels));
        std::sort(errors.begin(), errors.end());
        EXPECT_LT(errors[errors.size() / 2], 0.002);
        EXPECT_LT(errors[std::size_t(0.95 * double(errors.size() - 1))], 0.5 * saved.settings().voxelSizeMetres);
    }
}

TEST(RoomModelFile, CorruptOrMismatchedFilesAreRefusedAndChangeNothing) {
    const SyntheticRoom room;
    const fs::path folder = test::scratchDir("room_model_file_bad");
    const fs::path good = folder / "room.lsroom";
    saveRoomModel(fusedRoom(room), good);
    const std::string bytes = readBytes(good);

    RoomModel target = fusedRoom(room);
    const std::size_t views = target.views().size();
    const auto expectRefused = [&](const fs::path& file, const std::string& cause) {
        const std::string message = errorOf([&] { loadRoomModelInto(target, file); });
        EXPECT_NE(message.find(file.string()), std::string::npos) << message;
        EXPECT_NE(message.find(cause), std::string::npos) << message;
        EXPECT_EQ(target.views().size(), views) << "a refused file changed the model";
    };
    expectRefused(folder / "missing.lsroom", "no such room model file");
    writeBytes(folder / "text.lsroom", "{\"not\": \"a room model\"}\n");
    expectRefused(folder / "text.lsroom", "not a lightskin room model file");
    writeBytes(folder / "cut.lsroom", bytes.substr(0, bytes.size() / 2));
    expectRefused(folder / "cut.lsroom", "checksum");
    std::string flipped = bytes;
    flipped[bytes.size() / 2] = char(flipped[bytes.size() / 2] ^ 0x10);
    writeBytes(folder / "flipped.lsroom", flipped);
    expectRefused(folder / "flipped.lsroom", "checksum");

    RoomModelSettings other = roomSettings(room);
    other.voxelSizeMetres = 0.05;
    RoomModel otherGrid = RoomModel::create(other);
    const std::string message = errorOf([&] { loadRoomModelInto(otherGrid, good); });
    EXPECT_NE(message.find("/grid/voxelSizeMetres"), std::string::npos) << message;
    EXPECT_EQ(otherGrid.integratedFrames(), 0);
}

TEST(RoomModelFile, NeverReplacesAFileItDidNotWrite) {
    const SyntheticRoom room;
    const fs::path folder = test::scratchDir("room_model_file_destination");
    const fs::path notes = folder / "notes.txt";
    writeBytes(notes, "the user's notes\n");
    const RoomModel model = fusedRoom(room);
    EXPECT_NE(errorOf([&] { saveRoomModel(model, notes); }).find("not a lightskin room model"), std::string::npos);
    EXPECT_EQ(readBytes(notes), "the user's notes\n");
    EXPECT_NE(errorOf([&] { saveRoomModel(model, folder); }).find("not a lightskin room model"), std::string::npos);
    EXPECT_NE(errorOf([&] { saveRoomModel(model, folder / "no" / "room.lsroom"); }).find("does not exist"),
              std::string::npos);
    // Its own file is replaced, and no temporary file is left behind.
    const fs::path file = folder / "room.lsroom";
    saveRoomModel(model, file);
    saveRoomModel(model, file);
    int entries = 0;
    for ([[maybe_unused]] const auto& entry : fs::directory_iterator(folder)) ++entries;
    EXPECT_EQ(entries, 2); // notes.txt and room.lsroom
}

TEST(RoomModelFile, ARoomMemoryStartsWithTheLoadedRoom) {
    const SyntheticRoom room;
    const fs::path file = test::scratchDir("room_model_file_memory") / "room.lsroom";
    const RoomModel saved = fusedRoom(room);
    saveRoomModel(saved, file);
    RoomMemorySettings settings;
    settings.model = roomSettings(room);
    RoomMemory memory = RoomMemory::create(settings);
    memory.loadModel(file);
    EXPECT_GT(memory.model().integratedFrames(), 0);
    cv::Mat before, after;
    const Pose novel = lookAt({1.65, 0.35, 1.68}, kTarget);
    saved.renderDepthInto(novel, syntheticRoomIntrinsics(), before);
    memory.model().renderDepthInto(novel, syntheticRoomIntrinsics(), after);
    EXPECT_GT(cv::countNonZero(after), int(0.97 * double(cv::countNonZero(before)))); // as in the round trip above
}

} // namespace
} // namespace lightskin::roommodel
