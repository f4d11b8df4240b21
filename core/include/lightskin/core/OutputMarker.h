#pragma once
// The file every lightskin command writes first into an output folder it makes (docs/CLI.md): it
// holds the command line, and its presence is what lets `--overwrite` delete the folder's contents
// (a folder without it is the user's, never deleted). Writers that insist on an empty folder
// (capture::RecordingWriter, capture::writeFakenectDump) accept one that holds only this file.

#include <filesystem>
#include <system_error>

namespace lightskin {

inline constexpr const char* kOutputMarkerName = ".lightskin-output";

/// Whether `folder` is empty or holds nothing but kOutputMarkerName (false when it cannot be listed).
inline bool isEmptyOutputFolder(const std::filesystem::path& folder) {
    std::error_code error;
    for (std::filesystem::directory_iterator it(folder, error), end; !error && it != end; it.increment(error))
        if (it->path().filename() != kOutputMarkerName) return false;
    return !error;
}

} // namespace lightskin
