#pragma once
// A room model on disk, so that a session starts with the room known (`lightskin replay|live --room-model`,
// `--save-room-model`; docs/ROOMMODEL.md "Saving and loading").
//
// What is saved: the model's surfaces rendered as depth from its views (RoomModel::views(): cameras spaced at
// least 0.25 m or 15 degrees apart, up to 128), with the grid's settings. Loading fuses those depth images
// into an empty model of the same grid, so the loaded model holds the surfaces the saved one showed from where
// the room was seen (not its voxel weights: a surface seen by n views starts with weight n).
//
// The file: the text "lightskin-room-model\n", a little-endian uint64 byte count and a JSON header (format,
// version, the grid's settings, each view's pose and intrinsics), each view's depth as little-endian uint16 in
// units of kDepthUnitMetres (0 = no surface) row by row, and a little-endian uint64 FNV-1a hash of every byte
// before it. A file whose hash, sizes or header do not check out is refused before anything is fused.

#include <lightskin/roommodel/RoomModel.h>

#include <filesystem>

namespace lightskin::roommodel {

/// Depth quantum of a saved view, metres (uint16: up to 32.7 m, beyond any maxDepthMetres allowed).
inline constexpr double kDepthUnitMetres = 0.0005;

/// Whether `file` is a regular file that starts as a room model file does (written by saveRoomModel).
bool isRoomModelFile(const std::filesystem::path& file);

/// Throws lightskin::Error naming `file` when saving there would replace something else than a room model file
/// (a folder, another file) or its folder does not exist. Writes nothing: for checking before a run.
void checkRoomModelDestination(const std::filesystem::path& file);

/// Writes `model` to `file`: to a temporary file in the same folder, renamed over `file` when complete (a file that
/// cannot be written completely leaves `file` as it was). Throws lightskin::Error naming the file and the cause,
/// also for any destination checkRoomModelDestination refuses.
void saveRoomModel(const RoomModel& model, const std::filesystem::path& file);

/// Replaces `model`'s surfaces and views by the file's. The file's grid (bounds, up, voxel size, truncation) must be
/// the model's. Throws lightskin::Error naming the file and the cause (missing, not a room model, corrupt or cut
/// short, another grid, a bad view), and then leaves `model` as it was.
void loadRoomModelInto(RoomModel& model, const std::filesystem::path& file);

} // namespace lightskin::roommodel
