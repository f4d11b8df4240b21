#pragma once
// One fixed piece of work that a frame hands to its own thread and collects later in the same frame.

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace lightskin::mr {

/// Runs `body` on a thread of its own at each launch(); wait() returns when that run has finished and
/// rethrows what it threw. The body is fixed at construction, so a launch allocates nothing: what the run
/// reads and writes is the owner's state, which the owner leaves alone between launch() and wait().
/// launch() and wait() belong to one thread; a launch while a run is pending waits for it first.
class BackgroundTask {
public:
    explicit BackgroundTask(std::function<void()> body);
    /// Waits for a pending run (its error is dropped), then ends the thread.
    ~BackgroundTask();
    BackgroundTask(const BackgroundTask&) = delete;
    BackgroundTask& operator=(const BackgroundTask&) = delete;

    void launch();
    /// Blocks until the last launch's run has finished; rethrows its exception (once).
    void wait();
    /// wait() that drops the run's exception: for unwinding after an error of the caller's own.
    void waitQuietly() noexcept;

private:
    void run();

    std::function<void()> body_;
    std::mutex mutex_;
    std::condition_variable changed_;
    bool stop_ = false, started_ = false, pending_ = false; // under mutex_
    std::exception_ptr error_;                             // under mutex_
    std::thread thread_;                                   // last: started once the members above exist
};

} // namespace lightskin::mr
