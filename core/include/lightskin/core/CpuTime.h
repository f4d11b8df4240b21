#pragma once
// CPU time of the process (every thread) and of the calling thread, in milliseconds. On a shared machine these
// count only this program's work, where wall time also counts the other processes' turns.

#include <ctime>

namespace lightskin {

inline double processCpuMs() noexcept {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

inline double threadCpuMs() noexcept {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

} // namespace lightskin
