#pragma once
// Stopping a benchmark early (Ctrl-C or SIGTERM in the `lightskin bench*` commands) without losing what it
// measured: a benchmark asks between measurements, never inside a GL frame, so every result it keeps is whole;
// it then writes its outputs as usual, marked interrupted ("status": "interrupted" in its JSON).
#include <cstdio>
#include <functional>
#include <string>
#include <utility>

namespace lightskin::bench {

/// Asked between measurements: true = stop now and keep what was measured. Empty: never.
using StopRequested = std::function<bool()>;

/// A benchmark's view of StopRequested. Once it said stop it stays stopped, so the nested loops around a
/// measurement all leave on the same answer, and the outputs can ask stopped() afterwards.
class StopCheck {
public:
    explicit StopCheck(StopRequested requested)
        : requested_(std::move(requested)) {}

    /// Asks (until the first yes); true = stop.
    bool operator()() {
        if (!stopped_ && requested_) stopped_ = requested_();
        return stopped_;
    }
    bool stopped() const { return stopped_; }

private:
    StopRequested requested_;
    bool stopped_ = false;
};

/// The last line of a stopped benchmark's output (stdout, a report file): what the lines above it are.
inline std::string interruptedLine(const std::string& bench) {
    return bench + ": interrupted; the results above are those measured before the stop";
}
inline void printInterrupted(const std::string& bench) {
    std::printf("%s\n", interruptedLine(bench).c_str());
    std::fflush(stdout);
}

} // namespace lightskin::bench
