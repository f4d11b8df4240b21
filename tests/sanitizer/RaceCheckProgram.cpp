// ThreadSanitizer builds only: proves that cmake/sanitizers/tsan.supp does not hide a data race of ours inside
// a oneTBB parallel region. It runs a region shaped like the CPU GI backend's (tbb::task_arena, parallel_for
// over one index per thread with the static partitioner, fork and join declared by TsanParallelRegion) whose
// two tasks wait for each other, so that they run on two threads, and then both write one counter of this
// program (the race), or, with --clean, each its own slot. tests/sanitizer/CheckRaceReport.cmake requires
// ThreadSanitizer to report the race with this program's function on both stacks, and the clean run to pass.
#include "common/src/TsanParallelRegion.h"

#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>
#include <oneapi/tbb/task_arena.h>
#include <thread>

namespace {

using lightskin::gi::detail::TsanParallelRegion;

constexpr int kThreads = 2;

struct Region {
    bool clean = false;
    int sharedCounter = 0;                // both tasks write it unless clean
    std::array<int, kThreads> ownSlots{}; // one per task
    // Relaxed on purpose: a relaxed atomic orders nothing for TSan, so the barrier adds no happens-before edge.
    std::atomic<int> arrived{0};
    std::atomic<bool> timedOut{false};
    TsanParallelRegion region; // last: the fork edge follows the fields above
};

// Returns once both tasks have arrived (then they run on two threads at once), or after 30 s.
void waitForTheOtherTask(Region& r) {
    r.arrived.fetch_add(1, std::memory_order_relaxed);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (r.arrived.load(std::memory_order_relaxed) < kThreads) {
        if (std::chrono::steady_clock::now() > deadline) {
            r.timedOut.store(true, std::memory_order_relaxed);
            return;
        }
        std::this_thread::yield();
    }
}

[[gnu::noinline]] void writeFromTask(Region& r, std::size_t task) {
    if (r.clean)
        r.ownSlots[task] = int(task) + 1;
    else
        r.sharedCounter = int(task) + 1;
}

} // namespace

int main(int argc, char** argv) {
    Region r;
    r.clean = argc > 1 && std::strcmp(argv[1], "--clean") == 0;
    tbb::task_arena arena(kThreads);
    {
        Region* const context = &r;
        arena.execute([context] {
            tbb::parallel_for(
                tbb::blocked_range<std::size_t>(0, kThreads, 1),
                [context](const tbb::blocked_range<std::size_t>& tasks) {
                    Region& c = *TsanParallelRegion::captured(context);
                    c.region.taskBegin();
                    waitForTheOtherTask(c);
                    for (std::size_t t = tasks.begin(); t < tasks.end(); ++t) writeFromTask(c, t);
                    c.region.taskEnd();
                },
                tbb::static_partitioner());
        });
    }
    if (r.timedOut.load()) {
        std::fprintf(stderr, "lightskin race check: the two tasks never ran at once (one thread only?)\n");
        return 2;
    }
    std::printf("lightskin race check: finished (slots %d %d, counter %d)\n", r.ownSlots[0], r.ownSlots[1],
                r.sharedCounter);
    return 0;
}
