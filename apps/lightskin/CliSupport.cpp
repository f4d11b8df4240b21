#include "CliSupport.h"

#include "Commands.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>
#include <lightskin/core/OutputMarker.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <iostream>
#include <iterator>
#include <mutex>
#include <optional>
#include <poll.h>
#include <signal.h>
#include <sstream>
#include <streambuf>
#include <system_error>
#include <unistd.h>
#include <utility>
#include <vector>

namespace lightskin::apps {

namespace fs = std::filesystem;

CLI::Option* addOverwriteFlag(CLI::App* command, bool& overwrite) {
    return command->add_flag("--overwrite", overwrite,
                             "Use an existing output folder even when it is not empty: its contents are deleted first");
}

CLI::Validator atLeast(std::int64_t minimum) {
    return CLI::Validator(
        [minimum](std::string& text) -> std::string {
            std::size_t used = 0;
            long long value = 0;
            try {
                value = std::stoll(text, &used);
            } catch (const std::exception&) {
                used = 0;
            }
            if (used == 0 || used != text.size() || value < minimum)
                return "expected an integer >= " + std::to_string(minimum) + ", got '" + text + "'";
            return {};
        },
        "INT>=" + std::to_string(minimum));
}

CLI::Validator oneOf(std::vector<std::string> words) {
    return CLI::Validator(
        [words = std::move(words)](std::string& text) -> std::string {
            for (const std::string& word : words)
                if (text == word) return {};
            std::string list;
            for (const std::string& word : words) list += (list.empty() ? "" : ", ") + word;
            return "expected one of: " + list + "; got '" + text + "'";
        },
        "");
}

namespace {

std::string errnoText(int error) { return std::error_code(error, std::generic_category()).message(); }

/// The folder a new `folder` would be created in: its nearest existing ancestor.
fs::path nearestExisting(const fs::path& folder) {
    fs::path at = fs::absolute(folder).lexically_normal();
    std::error_code ec;
    while (!at.empty() && !fs::exists(at, ec)) {
        if (at == at.parent_path()) break;
        at = at.parent_path();
    }
    return at;
}

/// `path` with symbolic links resolved as far as it exists (weakly_canonical), absolute either way.
fs::path canonicalPath(const fs::path& path) {
    std::error_code ec;
    fs::path canonical = fs::weakly_canonical(fs::absolute(path, ec), ec);
    return ec ? fs::absolute(path).lexically_normal() : canonical;
}

/// Whether `outer` is `inner` or one of its ancestors (whole path components).
bool holds(const fs::path& outer, const fs::path& inner) {
    auto o = outer.begin(), i = inner.begin();
    for (; o != outer.end(); ++o, ++i) {
        if (o->empty() && std::next(o) == outer.end()) break; // a trailing separator
        if (i == inner.end() || *o != *i) return false;
    }
    return true;
}

/// The text of a CLI11 validator's failure for one list item, or "" when every item passes.
template <typename CheckItem>
std::string checkListItems(const std::string& text, bool allowEmpty, CheckItem checkItem) {
    if (text.empty()) return allowEmpty ? "" : "expected a comma-separated list, got an empty value";
    std::stringstream stream(text);
    std::string item;
    std::size_t items = 0;
    while (std::getline(stream, item, ',')) {
        ++items;
        if (std::string failure = checkItem(item); !failure.empty()) return failure;
    }
    if (items == 0 || text.back() == ',') return "expected a comma-separated list, got '" + text + "'";
    return {};
}

/// `text` as a whole as a finite number, or nullopt.
std::optional<double> finiteNumber(const std::string& text) {
    if (text.empty() || std::isspace(static_cast<unsigned char>(text.front())) != 0) return std::nullopt;
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(text.c_str(), &end);
    if (end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(value)) return std::nullopt;
    return value;
}

std::string numberText(double value) {
    std::ostringstream text;
    text << value;
    return text.str();
}

} // namespace

std::string commandLineText() {
    std::string line;
    for (const char* argument : programArguments()) {
        const std::string word(argument);
        const bool plain =
            !word.empty() && word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                                    "0123456789-_./=,:+@%") == std::string::npos;
        std::string quoted = "'";
        for (const char c : word) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
        line += (line.empty() ? "" : " ") + (plain ? word : quoted + "'");
    }
    return line;
}

void checkNotAnInput(const fs::path& output, const InputPaths& inputs, std::string_view option) {
    const fs::path target = canonicalPath(output);
    std::error_code ec;
    for (const fs::path& input : inputs) {
        if (input.empty() || !fs::exists(input, ec)) continue;
        const fs::path source = canonicalPath(input);
        const char* relation = target == source        ? "is the input "
                               : holds(target, source) ? "holds the input "
                               : holds(source, target) ? "lies inside the input "
                                                       : nullptr;
        if (relation != nullptr)
            throw Error(output.string(), std::nullopt,
                        std::string(option) + " " + relation + input.string() +
                            ": an output never replaces what the command reads; choose another path");
    }
}

CLI::Validator finiteIn(double minimum, double maximum) {
    const std::string range = "[" + numberText(minimum) + ", " + numberText(maximum) + "]";
    return CLI::Validator(
        [minimum, maximum, range](std::string& text) -> std::string {
            const std::optional<double> value = finiteNumber(text);
            if (!value || *value < minimum || *value > maximum)
                return "expected a number in " + range + ", got '" + text + "'";
            return {};
        },
        "in " + range);
}

CLI::Validator integerList(std::int64_t minimum, std::int64_t maximum, bool allowEmpty) {
    const std::string range = "[" + std::to_string(minimum) + ", " + std::to_string(maximum) + "]";
    return CLI::Validator(
        [=](std::string& text) -> std::string {
            return checkListItems(text, allowEmpty, [&](const std::string& item) -> std::string {
                const std::optional<double> value = finiteNumber(item);
                if (!value || *value != std::floor(*value) || *value < double(minimum) || *value > double(maximum))
                    return "expected integers in " + range + ", got '" + item + "'";
                return {};
            });
        },
        "");
}

CLI::Validator numberList(double minimum, double maximum, bool allowEmpty) {
    const std::string range = "[" + numberText(minimum) + ", " + numberText(maximum) + "]";
    return CLI::Validator(
        [=](std::string& text) -> std::string {
            return checkListItems(text, allowEmpty, [&](const std::string& item) -> std::string {
                const std::optional<double> value = finiteNumber(item);
                if (!value || *value < minimum || *value > maximum)
                    return "expected numbers in " + range + ", got '" + item + "'";
                return {};
            });
        },
        "");
}

CLI::Validator sizeList(int maximumSide) {
    return CLI::Validator(
        [maximumSide](std::string& text) -> std::string {
            return checkListItems(text, false, [&](const std::string& item) -> std::string {
                const std::size_t x = item.find('x');
                const auto side = [&](const std::string& part) {
                    const std::optional<double> value = finiteNumber(part);
                    return value && *value == std::floor(*value) && *value >= 1 && *value <= maximumSide;
                };
                if (x == std::string::npos || !side(item.substr(0, x)) || !side(item.substr(x + 1)))
                    return "expected sizes WxH with sides in [1, " + std::to_string(maximumSide) + "], got '" + item +
                           "'";
                return {};
            });
        },
        "");
}

void checkOutputFolder(const fs::path& folder, bool overwrite, std::string_view option, const InputPaths& inputs) {
    const std::string name = folder.string();
    if (folder.empty()) throw Error(std::string(option), std::nullopt, "needs a folder name");
    checkNotAnInput(folder, inputs, option);
    std::error_code ec;
    const fs::file_status status = fs::status(folder, ec);
    if (fs::exists(status)) {
        if (!fs::is_directory(status))
            throw Error(name, std::nullopt, "exists and is not a folder (" + std::string(option) + " needs a folder)");
        if (::access(name.c_str(), W_OK | X_OK) != 0)
            throw Error(name, std::nullopt, "output folder is not writable: " + errnoText(errno));
        const bool empty = fs::is_empty(folder, ec);
        if (ec) throw Error(name, std::nullopt, "cannot list the output folder: " + ec.message());
        if (!empty && !overwrite)
            throw Error(
                name, std::nullopt,
                "output folder is not empty: choose a new one, or add --overwrite to delete its contents first");
        if (!empty) {
            // Deleting the folder we run in, or one holding it, would delete the caller's work.
            if (holds(canonicalPath(folder), canonicalPath(fs::current_path(ec))))
                throw Error(name, std::nullopt,
                            "--overwrite refuses to delete the current folder or one that holds it");
            if (!fs::is_regular_file(folder / kOutputMarkerName, ec))
                throw Error(name, std::nullopt,
                            std::string("--overwrite deletes only a folder a lightskin command wrote (it holds ") +
                                kOutputMarkerName +
                                "), and this one does not: choose a new folder, or empty it yourself");
        }
        return;
    }
    const fs::path parent = nearestExisting(folder);
    // A name longer than the file system allows fails only at mkdir (ENAMETOOLONG): refuse it now,
    // before anything is written.
    const long nameMax = ::pathconf(parent.c_str(), _PC_NAME_MAX);
    for (const fs::path& part : fs::absolute(folder).lexically_normal())
        if (nameMax > 0 && part.native().size() > static_cast<std::size_t>(nameMax))
            throw Error(name, std::nullopt,
                        "cannot create the output folder: the name '" + part.native().substr(0, 16) + "...' has " +
                            std::to_string(part.native().size()) + " characters, more than the " +
                            std::to_string(nameMax) + " the file system allows");
    if (!fs::is_directory(parent, ec))
        throw Error(name, std::nullopt, "cannot create the output folder: " + parent.string() + " is not a folder");
    if (::access(parent.c_str(), W_OK | X_OK) != 0)
        throw Error(name, std::nullopt,
                    "cannot create the output folder: " + parent.string() + " is not writable (" + errnoText(errno) +
                        ")");
}

void prepareOutputFolder(const fs::path& folder, bool overwrite, std::string_view option, const InputPaths& inputs) {
    checkOutputFolder(folder, overwrite, option, inputs);
    const std::string name = folder.string();
    std::error_code ec;
    if (overwrite && fs::is_directory(folder, ec)) {
        for (const fs::directory_entry& entry : fs::directory_iterator(folder, ec)) {
            fs::remove_all(entry.path(), ec);
            if (ec) throw Error(entry.path().string(), std::nullopt, "--overwrite cannot delete it: " + ec.message());
        }
        if (ec) throw Error(name, std::nullopt, "--overwrite cannot list the folder: " + ec.message());
    }
    fs::create_directories(folder, ec);
    if (ec) throw Error(name, std::nullopt, "cannot create the output folder: " + ec.message());
    std::ofstream marker(folder / kOutputMarkerName);
    marker << commandLineText() << "\n";
    if (!marker.flush())
        throw Error((folder / kOutputMarkerName).string(), std::nullopt, "cannot write the output folder's marker");
}

void checkOutputFile(const fs::path& file, const InputPaths& inputs, std::string_view option) {
    const std::string name = file.string();
    if (file.empty() || file.filename().empty())
        throw Error(std::string(option), std::nullopt, "needs a file name, got '" + name + "'");
    checkNotAnInput(file, inputs, option);
    std::error_code ec;
    if (fs::is_directory(file, ec))
        throw Error(name, std::nullopt, "is a folder (" + std::string(option) + " needs a file name)");
    const fs::path folder = file.has_parent_path() ? file.parent_path() : fs::path(".");
    if (!fs::exists(folder, ec))
        checkOutputFolder(folder, false, option); // can it be made (nothing written)?
    else if (!fs::is_directory(folder, ec))
        throw Error(folder.string(), std::nullopt,
                    "is not a folder (" + std::string(option) + " needs a file in a folder)");
    else if (::access(folder.c_str(), W_OK | X_OK) != 0)
        throw Error(folder.string(), std::nullopt, "folder is not writable (" + std::string(option) + ")");
}

fs::path findData(const fs::path& relative, std::string_view what) {
    std::vector<fs::path> roots;
    std::error_code ec;
    const fs::path program = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) roots.push_back(program.parent_path().parent_path() / "share" / "lightskin"); // <prefix>/bin/lightskin
#ifdef LIGHTSKIN_SOURCE_DIR
    roots.emplace_back(LIGHTSKIN_SOURCE_DIR);
#endif
    std::string searched;
    for (const fs::path& root : roots) {
        if (fs::exists(root / relative, ec)) return root / relative;
        searched += (searched.empty() ? "" : ", ") + root.string();
    }
    throw Error(relative.string(), std::nullopt,
                "cannot find the " + std::string(what) + " (looked in " + searched + "); give its path");
}

void resolveShippedData(CLI::App* command, std::vector<ShippedData> data) {
    command->parse_complete_callback([command, data = std::move(data)] {
        for (const ShippedData& d : data)
            if (command->count(d.option) == 0) *d.path = findData(*d.path, d.what).string();
    });
}

bool warnIfDeprecatedUsed(const CLI::App& command, const std::string& old, const std::string& replacement) {
    if (command.count(old) == 0) return false;
    // Both spellings given: neither may silently win.
    if (command.count(replacement) > 0)
        throw CLI::ValidationError(old, "is the deprecated spelling of " + replacement + "; give only " + replacement);
    log::warning(command.get_name() + ": " + old + " is deprecated, use " + replacement);
    return true;
}

std::string_view ThirdPartyOutputCapture::sourceOf(std::string_view line) {
    const auto starts = [&](std::initializer_list<std::string_view> prefixes) {
        for (const std::string_view prefix : prefixes)
            if (line.starts_with(prefix)) return true;
        return false;
    };
    if (starts({"libpng"})) return "libpng";
    if (starts({"[ WARN:", "[ERROR:", "[ INFO:", "[DEBUG:", "[FATAL:", "imread_", "imwrite_", "OpenCV", "VIDEOIO"}))
        return "OpenCV";
    if (starts({"OpenNI", "[OpenNI", "Warning: USB events thread"})) return "OpenNI2";
    if (starts({"Assimp", "assimp", "Info,  T", "Warn,  T", "Error, T", "Debug, T"})) return "assimp";
    if (starts({"MESA", "Mesa", "libEGL", "EGL", "llvmpipe"})) return "Mesa";
    return {};
}

namespace {

/// Where the user's terminal (or file) is: descriptor 2 until the capture moves it to a copy and
/// puts a pipe on descriptor 2.
std::atomic<int> terminalFd{STDERR_FILENO};

/// The filter behind `stderr` and std::cerr. Decides at each line start whether the line is a
/// library's (captured until its newline, then logged) or ours (written through at once, so
/// progress lines and an assertion message before abort() are never held back).
class StderrFilter {
public:
    void write(const char* data, std::size_t size) {
        std::vector<std::string> lines; // logged after unlocking: spdlog takes its own lock and writes here
        std::unique_lock lock(mutex_);
        while (size > 0) {
            if (atLineStart_) {
                const std::string_view rest(data, size);
                capturing_ = !ThirdPartyOutputCapture::sourceOf(rest).empty();
                atLineStart_ = false;
            }
            const char* newline = static_cast<const char*>(std::memchr(data, '\n', size));
            const std::size_t take = newline != nullptr ? std::size_t(newline - data) + 1 : size;
            if (capturing_) {
                captured_.append(data, take);
                if (newline != nullptr) lines.push_back(std::exchange(captured_, {}));
            } else {
                for (std::size_t done = 0; done < take;) {
                    const ssize_t n = ::write(terminalFd.load(), data + done, take - done);
                    if (n <= 0 && errno != EINTR) break;
                    if (n > 0) done += std::size_t(n);
                }
            }
            atLineStart_ = newline != nullptr;
            data += take;
            size -= take;
        }
        lock.unlock();
        for (std::string& line : lines) logLine(line);
    }
    void finish() {
        std::unique_lock lock(mutex_);
        std::string rest = std::exchange(captured_, {});
        lock.unlock();
        logLine(rest);
    }

private:
    static void logLine(std::string& line) {
        while (!line.empty() && (line.back() == '\n' || line.back() == '\r')) line.pop_back();
        if (!line.empty()) log::debug(std::string(ThirdPartyOutputCapture::sourceOf(line)) + ": " + line);
    }
    std::mutex mutex_;
    bool atLineStart_ = true, capturing_ = false;
    std::string captured_;
};

StderrFilter& filter() {
    static StderrFilter instance; // never destroyed before exit: `stderr` may be written until then
    return instance;
}

/// The filter of what reaches descriptor 2 directly (write(2, ...) in a library): its own line state,
/// so that its partial lines never mix with those of `stderr`. Never destroyed: the reader thread may
/// still run while static objects are destroyed after exit().
StderrFilter& descriptorFilter() {
    static StderrFilter* instance = new StderrFilter;
    return *instance;
}

ssize_t filterWrite(void*, const char* data, std::size_t size) {
    filter().write(data, size);
    return static_cast<ssize_t>(size);
}

class FilterStreambuf : public std::streambuf {
protected:
    std::streamsize xsputn(const char* data, std::streamsize size) override {
        filter().write(data, static_cast<std::size_t>(size));
        return size;
    }
    int_type overflow(int_type c) override {
        if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
        const char ch = traits_type::to_char_type(c);
        filter().write(&ch, 1);
        return c;
    }
};

} // namespace

namespace {
std::atomic<int> stopSignal{0};
std::atomic<bool> stopRequested{false};
std::atomic<bool> progressLines{true};

extern "C" void onStopSignal(int number) {
    stopSignal = number;
    stopRequested = true;
}
} // namespace

StopSignals::StopSignals() {
    stopSignal = 0;
    stopRequested = false;
    struct sigaction action {};
    action.sa_handler = &onStopSignal;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESTART;
    ::sigaction(SIGINT, &action, &previousInterrupt_);
    ::sigaction(SIGTERM, &action, &previousTerminate_);
}

StopSignals::~StopSignals() {
    // Once a stop was asked for, the command is finishing and about to exit with 130/143: a repeated Ctrl-C
    // (or SIGTERM) in those last moments must not kill it with the default action instead.
    if (stopRequested.load()) {
        ::signal(SIGINT, SIG_IGN);
        ::signal(SIGTERM, SIG_IGN);
        return;
    }
    ::sigaction(SIGINT, &previousInterrupt_, nullptr);
    ::sigaction(SIGTERM, &previousTerminate_, nullptr);
}

bool StopSignals::requested() { return stopRequested.load(); }
int StopSignals::signal() { return stopSignal.load(); }
int StopSignals::exitCode() {
    if (!stopRequested.load()) return 0;
    return 128 + (stopSignal.load() != 0 ? stopSignal.load() : SIGINT);
}
void StopSignals::request() { stopRequested = true; }

bool progressWanted() { return progressLines.load(); }
void setProgressWanted(bool wanted) { progressLines = wanted; }

bool stderrIsTerminal() { return ::isatty(terminalFd.load()) != 0; }

void ThirdPartyOutputCapture::restoreDescriptorForExec() {
    std::fflush(nullptr);
    const int terminal = terminalFd.load();
    if (terminal != STDERR_FILENO) ::dup2(terminal, STDERR_FILENO);
}

void ThirdPartyOutputCapture::readDescriptor() {
    char buffer[4096];
    for (;;) {
        pollfd ready{pipeRead_, POLLIN, 0};
        const int events = ::poll(&ready, 1, 50);
        if (events > 0) {
            const ssize_t n = ::read(pipeRead_, buffer, sizeof buffer);
            if (n > 0) {
                descriptorFilter().write(buffer, static_cast<std::size_t>(n));
                continue;
            }
            if (n < 0 && errno == EINTR) continue;
            break; // every writer closed it (0), or an error
        }
        if (events < 0 && errno == EINTR) continue;
        // Stop only once nothing is left: a child that inherited descriptor 2 may keep the pipe open.
        if (stopping_.load()) break;
    }
}

ThirdPartyOutputCapture::ThirdPartyOutputCapture() {
    // Descriptor 2 itself: libraries that write(2, ...) or fprintf to their own copy of it.
    int pipe[2] = {-1, -1};
    const int terminal = ::fcntl(STDERR_FILENO, F_DUPFD_CLOEXEC, 3);
    if (terminal >= 0 && ::pipe2(pipe, O_CLOEXEC) == 0) {
        std::fflush(stderr);
        if (::dup2(pipe[1], STDERR_FILENO) >= 0) {
            terminalFd = terminal;
            pipeRead_ = pipe[0];
            reader_ = std::thread([this] { readDescriptor(); });
        } else {
            ::close(pipe[0]);
            ::close(terminal);
        }
        ::close(pipe[1]);
    } else if (terminal >= 0) {
        ::close(terminal);
    }

    static FilterStreambuf cerrBuffer;
    std::FILE* filtered = ::fopencookie(nullptr, "w", cookie_io_functions_t{nullptr, &filterWrite, nullptr, nullptr});
    if (filtered == nullptr) return;
    std::setvbuf(filtered, nullptr, _IONBF, 0);
    std::fflush(stderr);
    // glibc's stdin/stdout/stderr are ordinary variables (glibc manual, "Standard Streams"):
    // libraries' fprintf(stderr, ...) (libpng's "libpng error: ..."), ours and spdlog's sink
    // (created after this) all write through the filter.
    originalStderr_ = stderr;
    stderr = filtered;
    originalCerr_ = std::cerr.rdbuf(&cerrBuffer); // OpenCV's log and imread messages
}

ThirdPartyOutputCapture::~ThirdPartyOutputCapture() {
    if (reader_.joinable()) {
        // Descriptor 2 back to the terminal closes the pipe's last writer (ours): the reader drains
        // what is left and ends.
        std::fflush(nullptr);
        const int terminal = terminalFd.load();
        ::dup2(terminal, STDERR_FILENO);
        terminalFd = STDERR_FILENO;
        ::close(terminal);
        stopping_ = true;
        reader_.join();
        ::close(pipeRead_);
        descriptorFilter().finish();
    }
    if (originalCerr_ != nullptr) std::cerr.rdbuf(originalCerr_);
    filter().finish();
}

} // namespace lightskin::apps
