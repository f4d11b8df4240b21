#include "BackgroundTask.h"

#include <utility>

namespace lightskin::mr {

BackgroundTask::BackgroundTask(std::function<void()> body)
    : body_(std::move(body)), thread_([this] { run(); }) {}

BackgroundTask::~BackgroundTask() {
    waitQuietly();
    {
        const std::lock_guard lock(mutex_);
        stop_ = true;
    }
    changed_.notify_all();
    thread_.join();
}

void BackgroundTask::launch() {
    waitQuietly();
    {
        const std::lock_guard lock(mutex_);
        error_ = nullptr;
        started_ = pending_ = true;
    }
    changed_.notify_all();
}

void BackgroundTask::wait() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [this] { return !pending_; });
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void BackgroundTask::waitQuietly() noexcept {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [this] { return !pending_; });
    error_ = nullptr;
}

void BackgroundTask::run() {
    std::unique_lock lock(mutex_);
    for (;;) {
        changed_.wait(lock, [this] { return stop_ || started_; });
        if (stop_) return;
        started_ = false;
        lock.unlock();
        std::exception_ptr failed;
        try {
            body_();
        } catch (...) {
            failed = std::current_exception();
        }
        lock.lock();
        error_ = failed;
        pending_ = false;
        changed_.notify_all();
    }
}

} // namespace lightskin::mr
