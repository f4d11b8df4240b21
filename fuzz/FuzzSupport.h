#pragma once
// Shared by the fuzz targets (fuzz/README.md). Code that only reads files gets each input written
// into a per-process scratch folder on tmpfs (/dev/shm: no disk traffic per execution).
//
// The contract every target checks: bad bytes are refused with lightskin::Error (caught here and
// ignored); anything else escaping — another exception type, a crash, a sanitizer report, a hang —
// is a finding.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <unistd.h>

namespace lightskin::fuzz {

/// The folder is created on first use and removed at normal exit; one per process, so parallel
/// fuzzing jobs and the CI replay never share files.
class ScratchFolder {
public:
    explicit ScratchFolder(const std::string& name) {
        const std::filesystem::path base = std::filesystem::exists("/dev/shm") ? std::filesystem::path("/dev/shm")
                                                                               : std::filesystem::temp_directory_path();
        path_ = base / ("lightskin-fuzz-" + name + "-" + std::to_string(::getpid()));
        std::filesystem::remove_all(path_);
        std::filesystem::create_directories(path_);
    }
    ~ScratchFolder() {
        std::error_code ignored;
        std::filesystem::remove_all(path_, ignored);
    }
    ScratchFolder(const ScratchFolder&) = delete;
    ScratchFolder& operator=(const ScratchFolder&) = delete;

    const std::filesystem::path& path() const noexcept { return path_; }

private:
    std::filesystem::path path_;
};

inline void writeFile(const std::filesystem::path& path, const std::uint8_t* data, std::size_t size) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
}

inline void writeFile(const std::filesystem::path& path, std::string_view text) {
    writeFile(path, reinterpret_cast<const std::uint8_t*>(text.data()), text.size());
}

} // namespace lightskin::fuzz
