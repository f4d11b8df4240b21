#pragma once
// Declares the fork and join of a oneTBB parallel region to ThreadSanitizer (no-ops in other builds).
//
// Why: TSan sees only synchronisation that instrumented code or its interceptors perform. Debian's libtbb
// is not built with TSan, and oneTBB hands tasks to its workers and waits for them inside that library,
// so TSan sees neither edge: it reports every input the calling thread wrote before a region and a worker
// reads (VAL arrays, receivers), and every result a worker writes and the caller reads after the region,
// as a data race, in every test of the CPU backend (docs/TESTING.md, "ThreadSanitizer"). oneTBB
// guarantees both edges (parallel_for returns after every task has finished; a task starts after it was
// spawned); this class states exactly those two and nothing else, so a race between two tasks of one
// region (two workers writing the same receiver, a worker reading what another writes) is still
// reported. The reports inside oneTBB's own header code (its task and range objects, created by one
// thread and run by another through the library) are suppressed by their top frame in
// cmake/sanitizers/tsan.supp.
//
// The task body itself is oneTBB's copy (inside its task object, written by whichever thread created
// the task), so the body must not read its captures before taskBegin(): it captures one pointer to a
// context on the caller's stack and reads that pointer through captured(), with TSan's read checks off
// for that one load; everything else it reads through the context, ordered by the fork edge.
//
// Use: construct one (in the context) on the calling thread right before the region; in every task
// body call captured(ctx)->region.taskBegin() first and taskEnd() last; let it go out of scope after
// the region.
#if defined(__SANITIZE_THREAD__)
#define LIGHTSKIN_TSAN_PARALLEL_REGION 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define LIGHTSKIN_TSAN_PARALLEL_REGION 1
#endif
#endif

#ifdef LIGHTSKIN_TSAN_PARALLEL_REGION
#include <sanitizer/tsan_interface.h>
// libtsan's dynamic annotations (as in valgrind's dynamic_annotations.h; no public header declares them)
extern "C" void AnnotateIgnoreReadsBegin(const char* file, int line);
extern "C" void AnnotateIgnoreReadsEnd(const char* file, int line);
#endif

namespace lightskin::gi::detail {

class TsanParallelRegion {
public:
#ifdef LIGHTSKIN_TSAN_PARALLEL_REGION
    /// Fork: what the calling thread did so far happens before every taskBegin().
    TsanParallelRegion() { __tsan_release(&fork_); }
    /// Join: every taskEnd() happens before what the calling thread does after this.
    ~TsanParallelRegion() { __tsan_acquire(&join_); }
    void taskBegin() const { __tsan_acquire(&fork_); }
    void taskEnd() const { __tsan_release(&join_); }
#else
    TsanParallelRegion() = default;
    void taskBegin() const {}
    void taskEnd() const {}
#endif
    TsanParallelRegion(const TsanParallelRegion&) = delete;
    TsanParallelRegion& operator=(const TsanParallelRegion&) = delete;

    /// A task body's captured context pointer, loaded with TSan's read checks off (see above).
    template <class Context>
    static Context* captured(Context* const& capture) {
#ifdef LIGHTSKIN_TSAN_PARALLEL_REGION
        AnnotateIgnoreReadsBegin(__FILE__, __LINE__);
        Context* const context = capture;
        AnnotateIgnoreReadsEnd(__FILE__, __LINE__);
        return context;
#else
        return capture;
#endif
    }

private:
#ifdef LIGHTSKIN_TSAN_PARALLEL_REGION
    // Only their addresses matter: TSan keys its synchronisation objects by address.
    mutable char fork_ = 0, join_ = 0;
#endif
};

} // namespace lightskin::gi::detail
