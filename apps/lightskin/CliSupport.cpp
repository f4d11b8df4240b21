#include "CliSupport.h"

#include <lightskin/core/Error.h>
#include <lightskin/core/Log.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <iostream>
#include <poll.h>
#include <system_error>
#include <unistd.h>

namespace lightskin::apps {

namespace fs = std::filesystem;

CLI::Option* addOverwriteFlag(CLI::App* command, bool& overwrite) {
    return command->add_flag("--overwrite", overwrite,
                             "Use an existing output folder even when it is not empty: its contents are deleted first");
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

} // namespace

void checkOutputFolder(const fs::path& folder, bool overwrite, std::string_view option) {
    const std::string name = folder.string();
    if (folder.empty()) throw Error(std::string(option), std::nullopt, "needs a folder name");
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
            const fs::path target = fs::weakly_canonical(folder, ec), cwd = fs::current_path(ec);
            const auto [end, rest] = std::mismatch(target.begin(), target.end(), cwd.begin(), cwd.end());
            if (end == target.end())
                throw Error(name, std::nullopt,
                            "--overwrite refuses to delete the current folder or one that holds it");
            (void)rest;
        }
        return;
    }
    const fs::path parent = nearestExisting(folder);
    if (!fs::is_directory(parent, ec))
        throw Error(name, std::nullopt, "cannot create the output folder: " + parent.string() + " is not a folder");
    if (::access(parent.c_str(), W_OK | X_OK) != 0)
        throw Error(name, std::nullopt,
                    "cannot create the output folder: " + parent.string() + " is not writable (" + errnoText(errno) +
                        ")");
}

void prepareOutputFolder(const fs::path& folder, bool overwrite, std::string_view option) {
    checkOutputFolder(folder, overwrite, option);
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

bool warnIfDeprecatedUsed(const CLI::App& command, const std::string& old, const std::string& replacement) {
    if (command.count(old) == 0) return false;
    log::warning(command.get_name() + ": " + old + " is deprecated, use " + replacement);
    return true;
}

std::string_view ThirdPartyOutputCapture::sourceOf(std::string_view line) {
    const auto has = [&](std::string_view text) { return line.find(text) != std::string_view::npos; };
    if (line.starts_with("libpng")) return "libpng";
    if (line.starts_with("[ WARN:") || line.starts_with("[ERROR:") || line.starts_with("[ INFO:") ||
        line.starts_with("[DEBUG:") || has("OpenCV") || has("imread_") || has("imwrite_"))
        return "OpenCV";
    if (has("OpenNI")) return "OpenNI2";
    if (has("ssimp") || line.starts_with("Info,  T") || line.starts_with("Warn,  T") || line.starts_with("Error, T"))
        return "assimp";
    if (has("MESA") || has("Mesa") || has("EGL") || has("llvmpipe")) return "Mesa";
    return "stderr";
}

namespace {

void logCaptured(std::string& pending, bool flushAll) {
    std::size_t start = 0;
    for (std::size_t end; (end = pending.find('\n', start)) != std::string::npos; start = end + 1) {
        const std::string_view line(pending.data() + start, end - start);
        if (!line.empty()) log::debug(std::string(ThirdPartyOutputCapture::sourceOf(line)) + ": " + std::string(line));
    }
    pending.erase(0, start);
    if (flushAll && !pending.empty()) {
        log::debug(std::string(ThirdPartyOutputCapture::sourceOf(pending)) + ": " + pending);
        pending.clear();
    }
}

} // namespace

ThirdPartyOutputCapture::ThirdPartyOutputCapture() {
    std::array<int, 2> data{}, wake{};
    std::fflush(stderr);
    const int saved = ::fcntl(STDERR_FILENO, F_DUPFD_CLOEXEC, 3);
    if (saved < 0) return;
    if (::pipe2(data.data(), O_CLOEXEC) != 0) {
        ::close(saved);
        return;
    }
    if (::pipe2(wake.data(), O_CLOEXEC) != 0) {
        for (const int fd : {saved, data[0], data[1]}) ::close(fd);
        return;
    }
    std::FILE* ours = ::fdopen(saved, "w");
    if (ours == nullptr) {
        for (const int fd : {saved, data[0], data[1], wake[0], wake[1]}) ::close(fd);
        return;
    }
    std::setvbuf(ours, nullptr, _IONBF, 0);
    ::dup2(data[1], STDERR_FILENO);
    ::close(data[1]);
    // glibc's stdin/stdout/stderr are ordinary variables (glibc manual, "Standard Streams"): our
    // fprintf(stderr, ...) and spdlog's sink (created after this) write to the saved descriptor.
    originalStderr_ = stderr;
    stderr = ours;
    savedStderr_ = saved;
    wakeWrite_ = wake[1];
    reader_ = std::thread([dataRead = data[0], wakeRead = wake[0]] {
        std::string pending;
        std::array<char, 4096> buffer{};
        std::array<pollfd, 2> fds{{{dataRead, POLLIN, 0}, {wakeRead, POLLIN, 0}}};
        bool stopping = false;
        while (true) {
            if (!stopping && ::poll(fds.data(), fds.size(), -1) < 0 && errno != EINTR) break;
            if (!stopping && fds[1].revents != 0) { // drain what is left without waiting for writers
                stopping = true;
                ::fcntl(dataRead, F_SETFL, O_NONBLOCK);
            }
            const ssize_t got = ::read(dataRead, buffer.data(), buffer.size());
            if (got > 0) {
                pending.append(buffer.data(), static_cast<std::size_t>(got));
                logCaptured(pending, false);
            } else if (got == 0 || (errno != EINTR && (stopping || errno != EAGAIN))) {
                break;
            }
        }
        logCaptured(pending, true);
        ::close(dataRead);
        ::close(wakeRead);
    });
}

ThirdPartyOutputCapture::~ThirdPartyOutputCapture() {
    if (savedStderr_ < 0) return;
    std::cerr.flush();
    std::fflush(originalStderr_);
    ::dup2(savedStderr_, STDERR_FILENO); // closes our end of the pipe: the reader sees the end
    ::close(wakeWrite_);
    reader_.join();
    // `stderr` keeps pointing at the saved descriptor (spdlog's sink holds that FILE*); both stay
    // open until the process ends.
}

} // namespace lightskin::apps
