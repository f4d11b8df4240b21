#pragma once
// Rules every `lightskin` subcommand follows (docs/CLI.md), written once:
//  - an output folder is new or empty, or refused unless --overwrite, which clears it first; the
//    check runs before anything is written (checkOutputFolder), the folder is made only after every
//    input was validated (prepareOutputFolder);
//  - an output (folder or file) is never an input, never holds one and never lies inside one, and
//    --overwrite deletes only a folder a lightskin command made (it holds kOutputMarker);
//  - data the program ships (the bunny PLY, sample recordings) is found relative to the installed
//    program or the build tree, never the current directory (findData);
//  - third-party libraries' console output (libpng, OpenCV, OpenNI2, assimp, Mesa) goes into our
//    log with its source instead of onto the terminal raw (ThirdPartyOutputCapture).

#include <CLI/CLI.hpp>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace lightskin::apps {

/// Adds `--overwrite` to `command` (clear an existing, non-empty output folder first).
CLI::Option* addOverwriteFlag(CLI::App* command, bool& overwrite);

/// The file prepareOutputFolder writes first into every output folder (holding the command line that
/// made it): --overwrite deletes the contents of a non-empty folder only when it is there, so it never
/// deletes a folder of the user's that a mistyped --out names.
inline constexpr const char* kOutputMarker = ".lightskin-output";

/// The files and folders a command reads (recording, scene file, meshes, textures, tag world,
/// caches, goldens...). Paths that do not exist are skipped; symbolic links are resolved.
using InputPaths = std::vector<std::filesystem::path>;

/// The process's command line as typed, words quoted for a POSIX shell where needed (report.json's
/// `command`, the output marker): running it again reproduces the run.
std::string commandLineText();

/// Throws lightskin::Error naming `option`, `output` and the input unless `output` is none of
/// `inputs`, holds none of them and lies inside none of them (compared as canonical paths).
void checkNotAnInput(const std::filesystem::path& output, const InputPaths& inputs, std::string_view option);

/// Validator for a finite number in [minimum, maximum] (NaN, inf and text refused with the range).
CLI::Validator finiteIn(double minimum, double maximum);

/// Validators for comma-separated lists, every item checked (the command converts them afterwards
/// without failing): integers in [minimum, maximum], finite numbers in [minimum, maximum], sizes
/// "WxH" with both sides in [1, maximumSide]. `allowEmpty`: "" is the empty list.
CLI::Validator integerList(std::int64_t minimum, std::int64_t maximum, bool allowEmpty = false);
CLI::Validator numberList(double minimum, double maximum, bool allowEmpty = false);
CLI::Validator sizeList(int maximumSide);

/// Throws lightskin::Error unless `file` can be written as a new or replaced file: not a folder, its
/// folder exists or can be made, and it is none of `inputs` (checkNotAnInput). Writes nothing.
void checkOutputFile(const std::filesystem::path& file, const InputPaths& inputs, std::string_view option);

/// Validator for counts and indices: an integer >= `minimum` ("expected an integer >= 1, got -1").
CLI::Validator atLeast(std::int64_t minimum);

/// Validator for a word from a fixed list, checked while the command line is parsed (exit 64):
/// "expected one of: gl, cpu; got 'gpu'". Shows nothing in --help (the option's text lists the words).
CLI::Validator oneOf(std::vector<std::string> words);

/// Throws lightskin::Error (naming `option` and `folder`) unless `folder` can become this command's
/// output folder: it is none of `inputs`, holds none and lies inside none (checkNotAnInput), and it
/// does not exist and its nearest existing parent is a writable folder, or it is an empty writable
/// folder, or (`overwrite`) a writable folder a lightskin command made (it holds kOutputMarker).
/// Writes nothing.
void checkOutputFolder(const std::filesystem::path& folder, bool overwrite, std::string_view option,
                       const InputPaths& inputs = {});

/// checkOutputFolder, then (`overwrite`) deletes the folder's contents, creates it and writes
/// kOutputMarker into it. Call it once every input is validated, right before the first write.
void prepareOutputFolder(const std::filesystem::path& folder, bool overwrite, std::string_view option,
                         const InputPaths& inputs = {});

/// A file shipped with lightskin, given relative to the source tree (e.g.
/// "tests/data/stanford-bunny/bun_zipper_res4.ply"): looked up in <prefix>/share/lightskin/ beside
/// the installed program (found through /proc/self/exe), then in the source tree this build was
/// configured from. Throws lightskin::Error naming `what` and the folders searched when missing.
std::filesystem::path findData(const std::filesystem::path& relative, std::string_view what);

/// Options whose default names data shipped with lightskin (a path relative to the source tree):
/// when the user gives no value, findData resolves the default after parsing, so the command works
/// from any folder. A value the user gives is used as given (relative to the current folder).
struct ShippedData {
    std::string option; ///< e.g. "--bunny"
    std::string* path;  ///< the option's variable, holding the default
    std::string what;   ///< for the error when missing, e.g. "Stanford bunny PLY"
};
void resolveShippedData(CLI::App* command, std::vector<ShippedData> data);

/// When the deprecated spelling `old` of an option was given to `command`, logs a warning naming
/// `replacement` and returns true; given together with `replacement`, a usage error (CLI::ValidationError). Deprecated
/// spellings are hidden from --help (docs/CLI.md lists them).
bool warnIfDeprecatedUsed(const CLI::App& command, const std::string& old, const std::string& replacement);

/// While alive, everything written to standard error goes through a filter: C's `stderr`, std::cerr
/// and descriptor 2 itself (libraries that write(2, ...) directly: a pipe on descriptor 2, read by a
/// thread). A line that starts like a third-party library's message ("libpng error: ...", OpenCV's
/// "[ WARN:...", "imread_(...)", OpenNI2, assimp, Mesa) is logged through lightskin::log at debug level
/// with that source named ("libpng: libpng error: ..."; shown with -v); every other line (our own
/// messages, the log itself) goes to the terminal's descriptor at once, unchanged (lines written to
/// descriptor 2 directly arrive through the thread, a moment later). One instance, in main(); `stderr`
/// keeps the filter until the process ends (spdlog's sink holds it), the destructor puts descriptor 2
/// back, drains the pipe and logs an unfinished captured line.
class ThirdPartyOutputCapture {
public:
    ThirdPartyOutputCapture();
    ~ThirdPartyOutputCapture();
    ThirdPartyOutputCapture(const ThirdPartyOutputCapture&) = delete;
    ThirdPartyOutputCapture& operator=(const ThirdPartyOutputCapture&) = delete;

    /// The library a line is attributed to, or empty for our own output (exposed for tests).
    static std::string_view sourceOf(std::string_view line);

    /// Puts the terminal back on descriptor 2 for a program this process exec()s (nothing reads the
    /// pipe after exec).
    static void restoreDescriptorForExec();

private:
    void readDescriptor();

    std::FILE* originalStderr_ = nullptr;
    std::streambuf* originalCerr_ = nullptr;
    int pipeRead_ = -1;
    std::atomic<bool> stopping_{false};
    std::thread reader_;
};

/// While alive, SIGINT (Ctrl-C, also a second and third one) and SIGTERM do not kill the process: they
/// ask the command to stop after the current frame, so it closes its video and writes its report
/// marked interrupted, then exits with exitCode() (128 + the signal: 130, 143). One at a time.
class StopSignals {
public:
    StopSignals();
    ~StopSignals();
    StopSignals(const StopSignals&) = delete;
    StopSignals& operator=(const StopSignals&) = delete;

    static bool requested();
    /// The signal that asked to stop (SIGINT, SIGTERM), or 0 when none did.
    static int signal();
    /// 128 + signal() when a signal asked to stop, 130 (as Ctrl-C) after request(), else 0.
    static int exitCode();
    /// Asks to stop as Ctrl-C would, without a signal (a closed window).
    static void request();

private:
    struct sigaction previousInterrupt_ {
    }, previousTerminate_{};
};

/// Whether progress lines are wanted: not with -q (log level warning or above).
bool progressWanted();
void setProgressWanted(bool wanted);

/// Whether standard error is a terminal (progress lines that rewrite themselves): the terminal's
/// descriptor, not descriptor 2, which ThirdPartyOutputCapture replaces by a pipe.
bool stderrIsTerminal();

} // namespace lightskin::apps
