// The plots of `lightskin bench` (see BenchPlots.h): a child process running bench_plots.py.
#include <lightskin/bench/BenchPlots.h>
#include <lightskin/core/Error.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <spawn.h>
#include <sys/wait.h>
#include <vector>

extern char** environ;

namespace lightskin::bench {

namespace {

// Exit statuses of bench_plots.py (its docstring).
constexpr int kExitBadInput = 2;
constexpr int kExitNoMatplotlib = 3;
// posix_spawn's child exits 127 when it cannot execute the program (as the shell does).
constexpr int kExitCannotExecute = 127;

std::string environmentOr(const char* name, const std::string& fallback) {
    const char* value = std::getenv(name);
    return value && *value ? std::string(value) : fallback;
}

std::string interpreter() {
    if (const char* value = std::getenv("LIGHTSKIN_PYTHON"); value && *value) return value;
    std::error_code ignored;
    return std::filesystem::exists("/usr/bin/python3", ignored) ? "/usr/bin/python3" : "python3";
}

/// Runs argv[0] (searched on PATH) and returns its exit status; nullopt when it could not be started.
std::optional<int> run(const std::vector<std::string>& argv) {
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str())); // posix_spawn's C signature
    args.push_back(nullptr);
    pid_t pid = 0;
    if (posix_spawnp(&pid, args[0], nullptr, nullptr, args.data(), environ) != 0) return std::nullopt;
    int status = 0;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) return std::nullopt;
    if (!WIFEXITED(status)) return -1;
    return WEXITSTATUS(status);
}

} // namespace

void removePlots(const std::string& outDir, const std::string& prefix) {
    for (const char* suffix : {".png", "-vs-brute.png", "-scaling.png", "-flicker.png", "-plots.json"}) {
        std::error_code ignored;
        std::filesystem::remove(std::filesystem::path(outDir) / (prefix + suffix), ignored);
    }
}

PlotOutcome drawPlots(const std::string& jsonFile, const std::string& outDir, const std::string& prefix) {
    removePlots(outDir, prefix);
    const std::string script = environmentOr("LIGHTSKIN_BENCH_PLOTS", LIGHTSKIN_BENCH_PLOT_SCRIPT);
    const std::string python = interpreter();
    const std::string howTo =
        "; the results are in " + jsonFile +
        ". To draw the plots: apt-get install python3-matplotlib, then `lightskin bench --from-json " + jsonFile +
        " --out " + outDir + "` (or python3 " + script + " " + jsonFile + " " + outDir + ")";
    if (!std::filesystem::exists(script))
        return {false, "plots skipped: the plot script " + script +
                           " is missing (set LIGHTSKIN_BENCH_PLOTS to bench/plots/bench_plots.py of a source tree)" +
                           howTo};
    const std::optional<int> status = run({python, script, jsonFile, outDir});
    if (!status || *status == kExitCannotExecute)
        return {false, "plots skipped: cannot run " + python + " (python3 is not installed)" + howTo};
    if (*status == kExitNoMatplotlib)
        return {false, "plots skipped: " + python + " has no matplotlib (python3-matplotlib is not installed)" + howTo};
    if (*status == kExitBadInput)
        throw Error(jsonFile, std::nullopt, "the plot script " + script + " rejected this file (its message is above)");
    if (*status != 0)
        throw Error(outDir, std::nullopt,
                    "the plot script " + script + " failed with exit status " + std::to_string(*status) +
                        " (its message is above)");
    return {true, "plots: " + outDir + "/" + prefix + "*.png (matplotlib; the list in " + prefix + "-plots.json)"};
}

} // namespace lightskin::bench
