#pragma once
// Rules every `lightskin` subcommand follows (docs/CLI.md), written once:
//  - an output folder is new or empty, or refused unless --overwrite, which clears it first; the
//    check runs before anything is written (checkOutputFolder), the folder is made only after every
//    input was validated (prepareOutputFolder);
//  - data the program ships (the bunny PLY, sample recordings) is found relative to the installed
//    program or the build tree, never the current directory (findData);
//  - third-party libraries' console output (libpng, OpenCV, OpenNI2, assimp, Mesa) goes into our
//    log with its source instead of onto the terminal raw (ThirdPartyOutputCapture).

#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <string>
#include <string_view>
#include <thread>

namespace lightskin::apps {

/// Adds `--overwrite` to `command` (clear an existing, non-empty output folder first).
CLI::Option* addOverwriteFlag(CLI::App* command, bool& overwrite);

/// Throws lightskin::Error (naming `option` and `folder`) unless `folder` can become this command's
/// output folder: it does not exist and its nearest existing parent is a writable folder, or it is
/// an empty writable folder, or (`overwrite`) a writable folder whose contents may be deleted.
/// Writes nothing.
void checkOutputFolder(const std::filesystem::path& folder, bool overwrite, std::string_view option);

/// checkOutputFolder, then (`overwrite`) deletes the folder's contents and creates it. Call it once
/// every input is validated, right before the first write.
void prepareOutputFolder(const std::filesystem::path& folder, bool overwrite, std::string_view option);

/// A file shipped with lightskin, given relative to the source tree (e.g.
/// "tests/data/stanford-bunny/bun_zipper_res4.ply"): looked up in <prefix>/share/lightskin/ beside
/// the installed program (found through /proc/self/exe), then in the source tree this build was
/// configured from. Throws lightskin::Error naming `what` and the folders searched when missing.
std::filesystem::path findData(const std::filesystem::path& relative, std::string_view what);

/// When the deprecated spelling `old` of an option was given to `command`, logs a warning naming
/// `replacement` and returns true. Deprecated spellings are hidden from --help (docs/CLI.md lists them).
bool warnIfDeprecatedUsed(const CLI::App& command, const std::string& old, const std::string& replacement);

/// While alive, file descriptor 2 is a pipe read by a thread that logs each line through
/// lightskin::log at debug level, tagged with its source ("libpng", "OpenCV", "OpenNI2", "assimp",
/// "Mesa" or "stderr"); C's `stderr` (our own messages and spdlog's sink) is moved to a copy of the
/// original descriptor, so only third-party writes to descriptor 2 or std::cerr are captured. The
/// destructor restores descriptor 2 and logs what remained. Without a working pipe it does nothing.
class ThirdPartyOutputCapture {
public:
    ThirdPartyOutputCapture();
    ~ThirdPartyOutputCapture();
    ThirdPartyOutputCapture(const ThirdPartyOutputCapture&) = delete;
    ThirdPartyOutputCapture& operator=(const ThirdPartyOutputCapture&) = delete;

    /// The source a captured line is attributed to (exposed for tests).
    static std::string_view sourceOf(std::string_view line);

private:
    int savedStderr_ = -1;
    int wakeWrite_ = -1; ///< closing it tells the reader to drain what is left and stop
    std::FILE* originalStderr_ = nullptr;
    std::thread reader_;
};

} // namespace lightskin::apps
