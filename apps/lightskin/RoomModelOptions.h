#pragma once
// --room-model and --save-room-model, which `replay` and `live` share (docs/ROOMMODEL.md "Saving and loading").
#include <lightskin/core/Error.h>
#include <lightskin/roommodel/RoomModelFile.h>

#include <CLI/CLI.hpp>

#include <filesystem>
#include <string>

namespace lightskin::apps {

struct RoomModelOptions {
    std::string load; ///< --room-model: the saved room model the room memory starts from (empty: none)
    std::string save; ///< --save-room-model: where the room memory's model is saved at the end (empty: nowhere)
};

inline void addRoomModelOptions(CLI::App* command, RoomModelOptions& options) {
    command->add_option("--room-model", options.load,
                        "Start the room memory from this saved room model (made by --save-room-model for the same "
                        "roomModel grid)");
    command->add_option("--save-room-model", options.save,
                        "At the end, save the room memory's model to this file (new, or one lightskin saved; "
                        "replaced only when complete)");
}

/// Before anything is written: where --save-room-model would write. A file in `outputFolder` (the command's own
/// output folder, which it makes once every input is checked) is checked when it is saved instead.
inline void checkRoomModelSave(const RoomModelOptions& options, const std::filesystem::path& outputFolder) {
    if (options.save.empty()) return;
    const bool inOutputFolder =
        !outputFolder.empty() && std::filesystem::weakly_canonical(std::filesystem::path(options.save).parent_path()) ==
                                     std::filesystem::weakly_canonical(outputFolder);
    if (!inOutputFolder) roommodel::checkRoomModelDestination(options.save);
}

/// Once the session is made: --save-room-model needs its room memory (`hasRoomMemory`) to run.
inline void requireRoomMemoryForSave(const RoomModelOptions& options, bool hasRoomMemory, const std::string& scene) {
    if (!options.save.empty() && !hasRoomMemory)
        throw Error("--save-room-model", std::nullopt,
                    "no room memory runs: " + scene +
                        " needs a roomModel block, and the poses must come from tag tracking (--pose tracking)");
}

} // namespace lightskin::apps
